"""Per-joint figures from a recording: metrics.json's lists, the printed table, the picture."""

from __future__ import annotations

import numpy as np
import pytest

from robot_controller.core.controller import state_layout
from robot_controller.scoring import plots, report
from robot_controller.scoring.bag_reader import Recording


def synthetic_recording(joint_errors_rad: list[float], names: list[str] | None = None) -> Recording:
    """A 6 s, 100 Hz run of ``len(joint_errors_rad)`` joints, each tracking a sine with a
    constant error (reference − true) of its own; commands k + 1 N·m peak on joint k."""
    n = len(joint_errors_rad)
    t = np.arange(0.0, 6.0, 0.01)
    phase = np.arange(n) * 0.3
    reference = np.sin(t[:, None] + phase)
    true = reference - np.asarray(joint_errors_rad)
    command = np.sin(t[:, None]) * (np.arange(n) + 1.0)
    values = {name: np.zeros((len(t), n)) for name in state_layout.FIELDS}
    values.update(reference=reference, measured=true + 0.001, command=command)
    rows = np.column_stack(
        [t, np.full(len(t), state_layout.STATUS_CODES["ok"]), t] + [values[name] for name in state_layout.FIELDS]
    )
    return Recording(
        state=state_layout.decode(rows, n),
        true_time_s=t,
        true_position=true,
        true_velocity=np.cos(t[:, None] + phase),
        true_effort=command,
        reading_stamp_s=t,
        reading_position=true + 0.001,
        recorded_joint_names=names or [],
    )


def test_score_gives_each_joint_and_the_worst_as_headline():
    values = report.score(synthetic_recording([0.002, -0.006], ["shoulder", "elbow"]))
    assert values["joint_names"] == ["shoulder", "elbow"]
    assert values["tracking_rms_rad_per_joint"] == pytest.approx([0.002, 0.006])
    assert values["tracking_max_rad_per_joint"] == pytest.approx([0.002, 0.006])
    assert values["tracking_rms_rad"] == pytest.approx(0.006)  # the elbow's, not the pooled 0.0045
    assert values["tracking_max_rad"] == pytest.approx(0.006)
    # reference − reading: the error less the reading's 1 mrad offset
    assert values["measured_rms_rad_per_joint"] == pytest.approx([0.001, 0.007])
    assert values["measured_rms_rad"] == pytest.approx(0.007)
    assert values["peak_torque_nm_per_joint"] == pytest.approx([1.0, 2.0], abs=1e-3)
    assert values["peak_torque_nm"] == values["peak_torque_nm_per_joint"][1]
    table = report.joint_table(values)
    assert table is not None and table.row_count == 2


def test_one_joint_keeps_its_figures_and_prints_no_joint_table():
    values = report.score(synthetic_recording([0.004]))
    assert values["joint_names"] == ["joint1"]  # no names recorded: numbered
    assert values["tracking_rms_rad"] == values["tracking_rms_rad_per_joint"][0] == pytest.approx(0.004)
    assert values["peak_torque_nm"] == values["peak_torque_nm_per_joint"][0]
    assert report.joint_table(values) is None


@pytest.mark.parametrize("joints", [1, 2, 7])
def test_the_picture_shows_every_joint(tmp_path, joints):
    import matplotlib

    matplotlib.use("Agg")
    from PIL import Image

    path = tmp_path / "tracking.png"
    plots.plot_tracking(synthetic_recording([0.001 * (k + 1) for k in range(joints)]), path, title=f"{joints}")
    width, height = Image.open(path).size
    if joints == 1:
        assert (width, height) == (1100, 880)  # the one-joint figure as it always was
    else:  # a row of three panels per joint
        assert width > 1100 and height > 220 * joints


def test_a_prismatic_joint_is_scored_shown_and_drawn_in_metres_and_newtons(tmp_path, monkeypatch):
    units = ["rad", "rad", "m"]
    recording = synthetic_recording([0.002, -0.001, 0.0004], ["shoulder", "elbow", "quill"])
    values = report.score(recording, units=units)
    assert values["joint_units"] == units
    assert values["tracking_rms_per_joint"] == pytest.approx([0.002, 0.001, 0.0004])
    assert values["tracking_rms_rad"] == pytest.approx(0.002) and values["tracking_rms_m"] == pytest.approx(0.0004)
    assert values["peak_torque_nm"] == pytest.approx(2.0, abs=1e-3)  # the quill's 3 N is a force
    assert values["peak_force_n"] == pytest.approx(3.0, abs=1e-3)
    assert not any(key.endswith("_rad_per_joint") or key.endswith("_nm_per_joint") for key in values)
    table = report.joint_table(values)
    assert [column.header for column in table.columns][1] == r"tracking\nRMS \[rad | m]".replace(r"\n", "\n")
    assert list(table.columns[0].cells) == ["shoulder", "elbow", r"quill \[m, N]"]
    # The worst of each unit in bold: the shoulder's and the quill's RMS, each a headline.
    assert [cell.startswith("[bold]") for cell in table.columns[1].cells] == [True, False, True]

    import matplotlib.figure

    drawn = []
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", lambda fig, *a, **k: drawn.append(fig))
    plots.plot_tracking(recording, tmp_path / "tracking.png", units=units)
    titles = [ax.get_title() for ax in drawn[0].axes[:3]]
    assert titles == ["position [rad | m]", "error [mrad | mm]", "effort [N·m | N]"]
    assert [ax.get_ylabel() for ax in drawn[0].axes[::3]] == [
        "shoulder\nposition [rad]",
        "elbow\nposition [rad]",
        "quill\nposition [m]",
    ]
    quill = ["quill\nposition [m]", "quill\nerror [mm]", "quill\nforce [N]"]
    assert [ax.get_ylabel() for ax in drawn[0].axes[6:9]] == quill
    legend = [text.get_text() for text in drawn[0].axes[0].get_legend().get_texts()]
    assert "true position (/sim/joint_states)" in legend  # a chain with a slide: positions, not angles
