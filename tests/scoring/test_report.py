"""Scoring offline: the motor's receipts paired with the controller's ticks; no reference in force while the
brakes hold; the armature the inertia adaptation learnt, read from its block."""

from types import SimpleNamespace

import numpy as np
import pytest

from robot_controller.core.controller import state_layout
from robot_controller.scoring.bag_reader import _law_terms
from robot_controller.scoring.report import (
    Recording,
    adapted_armature,
    brake_metrics,
    motor_latency_s,
    reference_in_force,
)


def test_each_receipt_pairs_with_the_latest_tick_that_issued_its_command():
    state = {
        "command": np.array([[1.0], [2.0], [1.0], [3.0]]),
        "measurement_stamp_s": np.array([0.00, 0.01, 0.02, 0.03]),
    }
    receipts = np.array(
        [
            [0.004, 1.0],  # tick 0
            [0.013, 2.0],  # tick 1
            [0.0235, 1.0],  # tick 2, not tick 0: the latest reading before the receipt
            [0.036, 3.0],  # tick 3
            [0.040, 9.0],
        ]
    )  # no tick issued 9.0: not a latency
    assert np.allclose(motor_latency_s(state, receipts), [0.004, 0.003, 0.0035, 0.006])


def _stalled_then_braked():
    """A loop tracking a 1 rad/s ramp whose ticks stop at 1.0 s; the drive brakes the arm at 1.01 s (where it
    stands) until the loop returns at 1.5 s."""
    ticks = np.round(np.concatenate([np.arange(0.0, 1.0 + 1e-9, 0.01), np.arange(1.5, 2.0, 0.01)]), 6)
    reference = ticks[:, None].copy()
    t = np.round(np.arange(0.0, 2.0, 0.001), 6)
    q = np.where(t < 1.01, t, np.where(t < 1.5, 1.01, t))[:, None]
    state = {"time_s": ticks, "reference": reference, "status": np.zeros(len(ticks))}
    zeros = np.zeros_like(q)
    return Recording(
        state, t, q, zeros, zeros, brakes_time_s=np.array([0.0, 1.01, 1.5]), brakes=np.array([[0.0], [1.0], [0.0]])
    )


def test_no_reference_is_in_force_while_the_brakes_hold_the_arm():
    recording = _stalled_then_braked()
    in_force, valid = reference_in_force(recording)
    t = recording.true_time_s
    assert not valid[(t >= 1.01) & (t < 1.5)].any()  # a category 0 stop: not tracking
    assert valid[(t < 1.01) | (t >= 1.5)].all()
    error = in_force[valid, 0] - recording.true_position[valid, 0]
    assert np.max(np.abs(error)) < 0.011  # without the brakes' window: the carried reference, 0.05 rad on
    assert np.max(np.abs(error)) > 0.0  # the period the last effort acted over is still scored


def test_brake_engagements_count_the_stops_after_the_start_and_their_time():
    recording = _stalled_then_braked()
    assert brake_metrics(recording, 0.0, 2.0) == {
        "brake_engagements": 1,
        "braked_s": pytest.approx(0.49),
        "brake_engagements_estop": 0,
        "braked_s_estop": 0.0,
    }
    assert brake_metrics(recording, 1.6, 2.0)["brake_engagements"] == 0
    assert brake_metrics(Recording({}, t_empty := np.zeros(0), t_empty, t_empty, t_empty), 0, 1)["braked_s"] == 0.0


def test_brakes_an_estop_held_are_counted_as_asked_for():
    recording = _stalled_then_braked()
    # The e-stop engages the brakes; on its release they wait for the drive's next effort, the same stop.
    recording.brakes_time_s = np.array([0.0, 1.01, 1.2, 1.5])
    recording.brakes = np.array([[0.0], [1.0], [1.0], [0.0]])
    recording.brakes_reasons = [frozenset(), frozenset({"estop"}), frozenset({"drive_timeout"}), frozenset()]
    figures = brake_metrics(recording, 0.0, 2.0)
    assert figures["brake_engagements"] == figures["brake_engagements_estop"] == 1
    assert figures["braked_s_estop"] == pytest.approx(0.49)
    recording.brakes_reasons = [frozenset(), frozenset({"drive_timeout"}), frozenset({"drive_timeout"}), frozenset()]
    assert brake_metrics(recording, 0.0, 2.0)["brake_engagements_estop"] == 0


def test_a_span_an_estop_joins_at_once_is_its_and_one_it_joins_late_is_a_fault():
    """The drive hears the e-stop first: the world brakes for its missing efforts, then the e-stop's own reason comes
    (0.19 s later here): the e-stop's. A fault braked for 0.7 s before someone pressed the e-stop stays a fault."""
    recording = _stalled_then_braked()
    recording.brakes_time_s = np.array([0.0, 0.5, 0.69, 1.5])
    recording.brakes = np.array([[0.0], [1.0], [1.0], [0.0]])
    recording.brakes_reasons = [frozenset(), frozenset({"drive_timeout"}), frozenset({"drive_timeout", "estop"})]
    recording.brakes_reasons.append(frozenset())
    assert brake_metrics(recording, 0.0, 2.0)["brake_engagements_estop"] == 1
    recording.brakes_time_s = np.array([0.0, 0.5, 1.2, 1.5])
    assert brake_metrics(recording, 0.0, 2.0)["brake_engagements_estop"] == 0


def _state_message(joint_count, names, blocks):
    """A /controller/state message as the node labels it: the standard blocks, then ``names``' blocks."""
    values = {name: np.zeros(joint_count) for name in state_layout.FIELDS}
    labels = [*state_layout.HEADER, *state_layout.FIELDS, *names]
    data = state_layout.encode(0.0, "ok", 0.0, joint_count, values, blocks)
    return SimpleNamespace(data=data, layout=SimpleNamespace(dim=[SimpleNamespace(label=label) for label in labels]))


def test_the_adapted_armature_is_the_last_finite_row_of_its_block_beside_a_laws_own_terms():
    armature = state_layout.ADAPTED_ARMATURE
    messages = [
        _state_message(2, ("gravity", armature), (np.ones(2), np.array([0.0, 0.01]))),
        _state_message(2, ("gravity", armature), (np.ones(2), np.array([0.0, 0.08]))),
        _state_message(2, ("gravity",), (np.ones(2),)),  # a message without the block: NaN there
    ]
    terms = _law_terms(messages, 2)
    assert set(terms) == {"gravity", armature} and np.all(terms["gravity"] == 1.0)
    assert adapted_armature(terms, 2) == [0.0, 0.08]
    assert adapted_armature(terms, 2, np.array([True, False, False])) == [0.0, 0.01]  # a scoring window
    assert adapted_armature({"gravity": terms["gravity"]}, 2) == [0.0, 0.0]  # adaptation off: learnt nothing
    # A reader of the standard blocks only sees the message as it was.
    assert list(state_layout.standard(messages[0].data, 2)) == messages[2].data[: state_layout.width(2)]
