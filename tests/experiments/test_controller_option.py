"""The harness takes any law: ``--controller SPEC`` on step, faults, exercise
disturbance and tune; ``compare --controllers`` with laws among the entries;
``tune`` of a law of one's own; and the examples/ laws track the sine.
In process (no ROS) except the one real step run."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from robot_controller import cli
from robot_controller import parameters as cfg
from robot_controller.experiments import compare, inprocess, laws
from tests.rostools import run_said

ROOT = Path(__file__).resolve().parents[2]
PD = str(ROOT / "examples" / "own_controller.py") + ":PDWithGravity"
EXAMPLES = (
    PD,
    str(ROOT / "examples" / "simple_pid_law.py") + ":SimplePidLaw",
    str(ROOT / "examples" / "python_control_law.py") + ":LqrComputedTorque",
)


@pytest.mark.parametrize("spec", EXAMPLES, ids=lambda s: s.rpartition(":")[2])
def test_each_example_tracks_the_sine_in_process(spec):
    params = laws.with_controller(cfg.load_stack(), spec)
    result = inprocess.simulate(params, duration_s=8.0)
    assert result.law_fault is None
    # Measured over 20 s, seed 0: PDWithGravity 1.39, SimplePidLaw 2.08, LqrComputedTorque 0.98 mrad.
    assert result.tracking_metrics()["tracking_rms_rad"] <= 0.020


@pytest.mark.parametrize(
    "argv",
    [
        ["step", "--controller", PD],
        ["faults", "--controller", PD],
        ["exercise", "disturbance", "--controller", PD],
        ["tune", "--controller", PD],
        ["step", "--controller", "lqr"],
    ],
    ids=lambda argv: " ".join(argv[:2]),
)
def test_every_verb_takes_a_controller(argv):
    args = cli.build_parser().parse_args(argv)
    assert args.controller == argv[-1]


def test_compare_takes_configurations_and_laws():
    args = cli.build_parser().parse_args(["compare", "--in-process", "--controllers", f"default,tutorial,{PD}"])
    assert args.controllers == ["default", "tutorial", PD] and args.in_process
    chosen = compare.contenders(args.controllers)
    assert [c.name for c in chosen] == ["default", "tutorial", "PDWithGravity"]
    assert chosen[2].overrides == {"controller_type": PD}
    # A configuration's name wins over the installed law of the same name.
    assert compare.contenders(["pid"])[0].overrides["estimator"] == "none"


@pytest.mark.parametrize(
    "argv",
    [
        ["step", "--controller", "no_such_file.py:Law"],
        ["tune", "--controller", "not_an_installed_law"],
        ["faults", "--controller", str(ROOT / "examples" / "own_controller.py") + ":NoSuchClass"],
        ["compare", "--controllers", "default,neither_a_configuration_nor_a_law"],
    ],
    ids=lambda argv: argv[0],
)
def test_a_bad_controller_is_one_line_and_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as stopped:
        cli.main(argv)
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err


def test_controller_only_for_the_disturbance_exercise(tmp_path, capsys):
    assert cli.main(["exercise", "windup", "--controller", "lqr", "--out", str(tmp_path / "w")]) == 2
    assert "disturbance" in capsys.readouterr().err


def test_compare_in_process_writes_a_row_per_entry(tmp_path):
    out = tmp_path / "compare"
    table = compare.compare(
        out, seeds=1, sine_duration_s=3.0, amplitude=0.5, progress=lambda _: None, controllers=["default", PD],
        in_process=True,
    )  # fmt: skip
    assert list(table) == ["default", "PDWithGravity"]
    written = json.loads((out / "compare.json").read_text())
    assert set(written) == {"default", "PDWithGravity"}
    for row in written.values():
        assert row["sine_tracking_rms_rad"]["mean"] < 0.01
        assert row["step_peak_torque_nm"]["mean"] <= 10.0
    md = (out / "compare.md").read_text()
    assert "| **default**" in md and "| **PDWithGravity**" in md


@pytest.mark.ros
def test_step_runs_a_plugin_law_on_the_real_graph(tmp_path, ros_domain):
    out = tmp_path / "step"
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "step", "--sim-time", "--controller", PD, "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    figures = json.loads((out / "metrics.json").read_text())
    assert figures["law_fault_ticks"] == 0
    assert figures["peak_torque_nm"] <= 10.0
    assert abs(figures["steady_state_error_rad"]) < 0.005
