"""``robot-controller score DIR``: a saved run re-scored in the units its metrics.json recorded."""

import json

import pytest

from robot_controller.cli import score
from robot_controller.scoring import report
from tests.scoring.test_per_joint import synthetic_recording


@pytest.mark.parametrize("saved", [{"joint_units": ["rad", "m"]}, {}, {"joint_units": ["m"]}])
def test_a_run_is_re_scored_in_its_saved_units(tmp_path, monkeypatch, capsys, saved):
    recording = synthetic_recording([0.002, 0.0005], ["elbow", "quill"])
    monkeypatch.setattr(report, "read_recording", lambda path: recording)
    (tmp_path / "metrics.json").write_text(json.dumps(saved))
    assert score.score(tmp_path, as_json=True) == 0
    values = json.loads(capsys.readouterr().out)
    if saved.get("joint_units") == ["rad", "m"]:
        assert values["joint_units"] == ["rad", "m"] and values["tracking_rms_m"] == pytest.approx(0.0005)
    else:  # none saved, or not one per joint: every joint revolute, as runs before units were recorded
        assert values["joint_units"] == ["rad", "rad"] and "tracking_rms_m" not in values
    assert values["tracking_rms_rad"] == pytest.approx(0.002)
