"""The controller comparison over the real graph in lockstep."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


@pytest.mark.slow
def test_compare_lists_every_controller(tmp_path, ros_domain):
    out = tmp_path / "compare"
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "compare", "--seeds", "1", "--duration", "3", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    table = (out / "compare.md").read_text()
    for name in ("tutorial", "pid", "pid_ff", "pid_ff_kf", "lqr"):
        assert f"| **{name}**" in table, name
    figures = json.loads((out / "compare.json").read_text())
    # the tutorial's controller lags the sine; ours tracks it
    assert figures["tutorial"]["sine_tracking_rms_rad"]["mean"] > 10 * figures["lqr"]["sine_tracking_rms_rad"]["mean"]
    assert (out / "compare.png").stat().st_size > 10_000


#: Relative: the two clocks reach a tick's time an ulp apart (``60 × 0.01`` in process, ns stamps in the graph),
#: which moves the figures by about 1e-9 of themselves (measured on 2026-12-07: at most 4.3e-9 over the six
#: configurations, five seeds each).
AGREE_REL = 1e-6


def test_compare_in_process_gives_the_graphs_figures_and_verdicts(tmp_path, ros_domain):
    # The default on the sine and the step, once on the sim-time graph and once in process: every figure the table
    # shows and compare judges is the graph's (the step's settling was 0.296 s in process against the graph's 0.190).
    said, figures = {}, {}
    for way, extra in (("graph", []), ("in_process", ["--in-process"])):
        out = tmp_path / way
        args = ["compare", "--controllers", "default", "--seeds", "1", "--duration", "4", "--out", str(out), *extra]
        proc = subprocess.run(
            [sys.executable, "-m", "robot_controller.cli", *args], capture_output=True, text=True, timeout=180
        )
        assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
        said[way] = [line for line in proc.stdout.splitlines() if "misses its target" in line]
        figures[way] = json.loads((out / "compare.json").read_text())["default"]
    assert said["in_process"] == said["graph"]
    assert set(figures["in_process"]) == set(figures["graph"])
    for key, graph in figures["graph"].items():
        ours, theirs = figures["in_process"][key]["mean"], graph["mean"]
        if theirs is None:  # never settled: null in JSON
            assert ours is None, key
        else:
            assert ours == pytest.approx(theirs, rel=AGREE_REL), key
