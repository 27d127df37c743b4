"""The end of ``robot-controller run`` through the real graph in lockstep: a verdict, a few lines after it,
and ``summary.md`` beside metrics.json; and the command as typed, which summary.md records."""

import json
import subprocess
import sys

import pytest

from robot_controller.cli.output import typed_command
from robot_controller.scoring import summary
from tests.rostools import run_said


@pytest.mark.parametrize(
    "argv, typed",
    [
        (["/venv/bin/robot-controller", "run", "--out", "my runs/a"], "robot-controller run --out 'my runs/a'"),
        (["/repo/robot_controller/cli/__main__.py", "run"], "python -m robot_controller.cli run"),
    ],
)
def test_the_command_is_said_as_typed(argv, typed):
    assert typed_command(argv) == typed


@pytest.mark.ros
def test_a_lockstep_run_ends_with_its_verdict_a_few_lines_and_a_summary(tmp_path, ros_domain):
    out = tmp_path / "run"
    command = ["run", "--sim-time", "--duration", "2", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *command], capture_output=True, text=True, timeout=240
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    said = proc.stdout.splitlines()
    end = said[said.index("ok") + 1 :]
    assert 3 <= len(end) <= 14, "\n".join(end)
    assert not any(line.startswith("[") for line in end), "\n".join(end)  # no node speaks after the verdict
    metrics = json.loads((out / "metrics.json").read_text())
    tracking = summary.tracking_line(metrics)
    assert f"tracking     {tracking}" in end and "mrad" in tracking, "\n".join(end)
    assert any(line.startswith("files") and str(out) in line for line in end)

    text = (out / "summary.md").read_text()
    assert text.startswith(f"# Run {out.name}\n\n**ok**")
    assert f"python -m robot_controller.cli {' '.join(command)}" in text
    assert tracking in text and "one_dof, preset default, seed 0" in text
    assert "[tracking.png](tracking.png)" in text and "[bag/](bag/)" in text and (out / "tracking.png").is_file()


def test_compare_marks_the_targets_a_contender_missed_under_its_table(tmp_path, monkeypatch, capsys):
    from robot_controller import cli
    from robot_controller.experiments import compare

    def fake_compare(out, **_):
        table = {"default": {"sine_tracking_rms_rad": {"mean": 0.001}, "step_settling_time_s": {"mean": 0.296}}}
        (out / "compare.json").write_text(json.dumps(table))
        (out / "compare.md").write_text("# Controller comparison\n")

    monkeypatch.setattr(compare, "compare", fake_compare)
    assert cli.main(["compare", "--seeds", "1", "--out", str(tmp_path / "compare")]) == 0
    said = capsys.readouterr().out.splitlines()
    assert said[-1] == f"{summary.MISSED}: default: step settling 0.296 s (target ≤ 0.25 s)", said
