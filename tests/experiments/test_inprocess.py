"""The whole loop in one Python loop (no ROS): accuracy, determinism, limits,
and the planner's feasibility policy applied as the planner applies it."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import ArmDynamics
from robot_controller.core.reference import Chirp, Plan, Sine, make_trajectory, plan_trajectory
from robot_controller.experiments import inprocess
from robot_controller.parameters import consistency


@pytest.fixture(scope="module")
def default_run():
    return inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=3)


def test_default_preset_tracks_the_true_angle(default_run):
    assert default_run.tracking_metrics()["tracking_rms_rad"] < 0.003


def test_tutorial_preset_lags_as_the_tutorial_controller_does():
    rms = inprocess.simulate(cfg.load_stack("tutorial"), duration_s=8.0, seed=3).tracking_metrics()["tracking_rms_rad"]
    assert 0.1 < rms < 0.35


def test_same_seed_same_run(default_run):
    again = inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=3)
    np.testing.assert_array_equal(again.true_position, default_run.true_position)
    other = inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=4)
    assert not np.array_equal(other.measured, default_run.measured)


def test_torque_is_finite_and_within_the_limit(default_run):
    assert np.all(np.isfinite(default_run.command))
    assert np.max(np.abs(default_run.applied)) <= 10.0


def test_latency_compensation_holds_accuracy_under_measurement_delay():
    params = cfg.load_stack("default")
    delayed = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=0.02).tracking_metrics()
    assert delayed["tracking_rms_rad"] < 0.003
    params["pid_controller"]["latency_compensation"] = False
    uncompensated = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=0.02).tracking_metrics()
    assert uncompensated["tracking_rms_rad"] > 5 * delayed["tracking_rms_rad"]


@pytest.mark.parametrize("delay_s", [0.02, 0.04, 0.06])
def test_readings_up_to_60_ms_late_are_compensated_without_saturation(delay_s):
    run = inprocess.simulate(cfg.load_stack("default"), duration_s=6.0, seed=1, measurement_delay_s=delay_s)
    assert run.tracking_metrics()["tracking_max_rad"] < 0.01
    assert np.max(np.abs(run.command)) < 9.0


def test_the_default_survives_its_delay_margin_of_delay_nobody_accounts_for():
    # Stamped on arrival, the delay is invisible to the compensation: only the
    # loop's own margin (2 periods for the default LQR design with its disturbance
    # observer, 3 without it) keeps the loop stable.
    from robot_controller import resources
    from robot_controller.core.controller import JointController
    from robot_controller.core.model import ArmDynamics

    params = cfg.load_stack("default")
    controller = JointController(
        cfg.controller_config(params["pid_controller"], 1), 1, ArmDynamics(resources.default_urdf())
    )
    margin = controller.delay_margin_periods()
    assert margin >= 2
    run = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=margin * 0.01, delay_unstamped=True)
    assert np.max(np.abs(run.command)) < 10.0  # no saturation chatter
    # The arm follows where the late readings say it is: off by the speed times the delay (63 mrad),
    # and a little more where the filter, trusting its model, takes their pattern for a push (twice
    # in these 6 s: 101 mrad).
    assert run.tracking_metrics()["tracking_max_rad"] < 3.2 * margin * 0.01 * 2.0
    params["pid_controller"]["lqr_r"] = 0.01  # the old default's gains: no margin at all
    twitchy = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=0.02, delay_unstamped=True)
    assert np.max(np.abs(twitchy.command)) >= 10.0


# The ROS feasibility test's chirp: 1 rad, 0.5 → 3 Hz in 4.5 s, about 30 N·m against 8 usable.
CHIRP = dict(mode="chirp", amplitude=[1.0], frequency_hz=0.5, end_frequency_hz=3.0, sweep_time_s=4.5)
# The controller first leads the arm from where it rests onto the reference (0.3 to 0.8 s here).
ON_THE_REFERENCE_S = 1.0


def chirp_params(policy: str) -> cfg.Params:
    params = cfg.load_stack("default")
    params["trajectory_planner"].update(CHIRP, feasibility=policy)
    return params


def planner_plan(params: cfg.Params) -> Plan:
    """What the ROS planner does with these values (trajectory_planner._planned): its URDF's arm."""
    planner = params["trajectory_planner"]
    return plan_trajectory(
        make_trajectory(planner["mode"], **cfg.trajectory_kwargs(planner)),
        ArmDynamics(resources.resolve_urdf(planner["urdf_path"])),
        planner["torque_max"],
        margin=planner["feasibility_margin"],
        policy=planner["feasibility"],
        what=planner["mode"],
    )


def assert_follows(run, trajectory) -> None:
    """The controller's reference is ``trajectory``'s position at every tick once it is on it."""
    on = run.tick_time_s >= ON_THE_REFERENCE_S
    expected = np.array([trajectory.sample(t)[0] for t in run.tick_time_s[on]])
    np.testing.assert_allclose(run.reference[on], expected, rtol=0, atol=1e-9)


def test_an_infeasible_chirp_runs_slowed_as_the_planner_slows_it():
    params = chirp_params("scale")
    expected = planner_plan(params)
    assert isinstance(expected.trajectory, Chirp) and expected.result.scale > 1.5
    warnings: list[str] = []
    run = inprocess.simulate(params, duration_s=6.0, seed=1, on_warning=warnings.append)
    assert warnings == [expected.warning] and "scaled in time ×" in warnings[0]
    assert_follows(run, expected.trajectory)
    # Within the limit all along, and on the reference.
    assert np.max(np.abs(run.applied)) < 9.0
    assert run.tracking_metrics()["tracking_max_rad"] < 0.01


def test_ignore_runs_the_chirp_as_it_is_and_it_saturates():
    params = chirp_params("ignore")
    original = make_trajectory("chirp", **cfg.trajectory_kwargs(params["trajectory_planner"]))
    warnings: list[str] = []
    run = inprocess.simulate(params, duration_s=6.0, seed=1, on_warning=warnings.append)
    assert warnings == [planner_plan(params).warning] and "(feasibility: ignore)" in warnings[0]
    assert_follows(run, original)
    assert np.max(np.abs(run.applied)) == pytest.approx(10.0)
    assert run.tracking_metrics()["tracking_max_rad"] > 0.3


def test_refuse_raises_the_planners_one_line_before_anything_runs():
    params = chirp_params("refuse")
    with pytest.raises(ConfigError) as refused:
        inprocess.simulate(params, duration_s=6.0, seed=1)
    with pytest.raises(ConfigError) as before_start:
        consistency.check_stack(params)
    message = str(refused.value)
    assert message == str(before_start.value)
    assert "\n" not in message
    assert message.startswith("trajectory_planner: the chirp needs ") and message.endswith(
        "; slow it down (feasibility: scale) or lower the amplitude"
    )


def test_the_in_process_plan_is_on_the_controllers_arm_model():
    # The controller believes in 12 times the URDF's inertia: the default sine needs about 10 N·m on
    # that arm, so the run slows it as the check before start judged (the URDF alone would leave it).
    params = cfg.load_stack("default")
    params["pid_controller"]["model_inertia"] = [1.0]
    assert planner_plan(params).warning is None
    plan = consistency.trajectory_plan(params)
    assert isinstance(plan.trajectory, Sine) and plan.trajectory.frequency_hz < 0.45
    warnings: list[str] = []
    run = inprocess.simulate(params, duration_s=3.0, seed=1, on_warning=warnings.append)
    assert warnings == [plan.warning]
    assert_follows(run, plan.trajectory)


@pytest.mark.slow
@pytest.mark.parametrize(
    "payload", [[3.0, 0.0, 0.0, 0.1], [3.0, 0.0, 0.0, 0.15], [1.5, 0.0, 0.0, 0.08], [3.0, 0.1, 0.0, 0.0]]
)
def test_the_panda_carries_a_payload_up_to_its_rated_3_kg_unknown_and_known(payload):
    """Within 5 mrad on every joint unknown (the LQR designed for it and the observer's allowance; the last load
    off the flange axis), within 2 mrad modelled (``model_payload``, as identify's overlay sets it)."""
    params = cfg.load_stack("default", robot="panda")
    params["simulator"]["payload"] = payload
    unknown = inprocess.simulate(params, duration_s=15.0, seed=0).tracking_metrics()
    assert max(unknown["tracking_rms_per_joint"]) <= 0.005
    params["pid_controller"]["model_payload"] = payload
    known = inprocess.simulate(params, duration_s=15.0, seed=0).tracking_metrics()
    assert max(known["tracking_rms_per_joint"]) <= 0.002
