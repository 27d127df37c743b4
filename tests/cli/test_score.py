"""``robot-controller score DIR``: a saved run re-scored in the units its metrics.json recorded."""

import json

import pytest

from robot_controller.cli.run import score
from robot_controller.scoring import report
from tests.scoring.test_per_joint import synthetic_recording


@pytest.mark.parametrize("saved", [{"joint_units": ["rad", "m"]}, {}, {"joint_units": ["m"]}])
def test_a_run_is_re_scored_in_its_saved_units(tmp_path, monkeypatch, capsys, saved):
    recording = synthetic_recording([0.002, 0.0005], ["elbow", "quill"])
    monkeypatch.setattr(report, "read_recording", lambda path: recording)
    (tmp_path / "metrics.json").write_text(json.dumps(saved))
    assert score(tmp_path, as_json=True) == 0
    values = json.loads(capsys.readouterr().out)
    if saved.get("joint_units") == ["rad", "m"]:
        assert values["joint_units"] == ["rad", "m"] and values["tracking_rms_m"] == pytest.approx(0.0005)
    else:  # none saved, or not one per joint: every joint revolute, as runs before units were recorded
        assert values["joint_units"] == ["rad", "rad"] and "tracking_rms_m" not in values
    assert values["tracking_rms_rad"] == pytest.approx(0.002)


def test_score_prints_a_few_lines_and_every_figure_with_all(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(report, "read_recording", lambda path: synthetic_recording([0.002, 0.0005], ["elbow", "quill"]))
    (tmp_path / "metrics.json").write_text(json.dumps({"joint_units": ["rad", "m"], "robot": "scara", "seed": 3}))
    (tmp_path / "params.yaml").write_text("pid_controller:\n  ros__parameters:\n    torque_max: [10.0, 40.0]\n")
    assert score(tmp_path) == 0
    short = capsys.readouterr().out.splitlines()
    assert short[0] == f"re-scored {tmp_path / 'bag'}" and len(short) <= 14, short
    assert any(
        line.startswith("tracking") and "RMS 2 mrad on elbow" in line and "0.5 mm on quill" in line for line in short
    )
    assert any(line.startswith("peak effort") and "1 N·m of 10 N·m (10 %) on elbow" in line for line in short), short
    assert short[-1].endswith(f"robot-controller score {tmp_path} --all") and "watchdog_ticks" not in "".join(short)
    assert score(tmp_path, every_figure=True) == 0
    table = capsys.readouterr().out
    assert "watchdog_ticks" in table and "control_ticks" in table and len(table.splitlines()) > 30


def test_score_judges_a_saved_run_against_the_band_it_ran_with(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(report, "read_recording", lambda path: synthetic_recording([0.03], ["elbow"]))
    (tmp_path / "metrics.json").write_text(json.dumps({"tracking_band_rad": 0.05}))
    assert score(tmp_path) == 0
    assert capsys.readouterr().out.splitlines()[1] == "ok"
    (tmp_path / "metrics.json").write_text(json.dumps({"tracking_band_rad": 0.02}))
    assert score(tmp_path) == 1
    said = capsys.readouterr().out.splitlines()
    assert (
        said[1]
        == said[-1]
        == "FAILED: tracking 30 mrad off its reference, beyond its 20 mrad tracking band; "
        + ("in its first 2 s 30 mrad off its reference, beyond its 20 mrad tracking band")
    )
    assert score(tmp_path, every_figure=True) == 1
    assert capsys.readouterr().out.splitlines()[-1].startswith("FAILED: tracking 30 mrad")
