"""Faults on the real graph (docs/design.md §4): a frozen node, an e-stop, a
configuration that disagrees. Each test runs the project's own commands on
its own ROS_DOMAIN_ID and judges the arm by the TRUE angle in the recording."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.controller import state_layout
from robot_controller.scoring import report
from tests.rostools import child_pid, run_said, run_while

pytestmark = pytest.mark.ros


def cli(*args, timeout=240, **kwargs):
    return subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *args], capture_output=True, text=True, timeout=timeout, **kwargs
    )


@pytest.mark.parametrize("world", ["paced", "wall clock"])
def test_frozen_sensor_and_frozen_controller_leave_the_arm_held(tmp_path, ros_domain, world):
    """``faults --quick`` in the default run's paced world, and with ``--wall-clock``."""
    proc = cli("faults", "--quick", "--out", str(tmp_path / "faults"), *(["--wall-clock"] if world != "paced" else []))
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    assert ["world", f"{world} (2 cases)"] in [line.split(None, 1) for line in proc.stdout.splitlines()], proc.stdout
    cases = {c["node"]: c for c in json.loads((tmp_path / "faults" / "faults.json").read_text())["cases"]}
    assert set(cases) == {"sensor_node", "pid_controller"}
    for case in cases.values():
        assert case["exit_code"] == 0 and "failure" not in case and case["world"] == world, case
        assert case["max_deviation_rad"] <= 0.1, case  # the arm never left the band the sine sweeps
        assert case["peak_torque_nm"] <= 10.0
        assert case["reacquire_s"] is not None, case  # back on the trajectory before the run ended
    # The paced world brakes the arm for either (it waits for each tick's effort, then goes on braked).
    assert cases["sensor_node"]["brake_engaged"]
    assert cases["pid_controller"]["brake_engaged"]
    if world == "paced":
        return
    # Wall clock. Sensor lost: a controlled stop on the model, then (0.1 s at rest) no commands and the
    # brake: open loop, a hold drifts. Controller lost: the motor's command timeout stopped the drive and
    # the brake held the arm.
    sensor_run = report.read_recording(tmp_path / "faults" / "sensor_node_stop_0.5s" / "bag")
    statuses = set(sensor_run.state["status"].astype(int).tolist())
    assert state_layout.STATUS_CODES["watchdog"] in statuses and state_layout.STATUS_CODES["reacquiring"] in statuses


def test_a_sensor_frozen_in_the_paced_world_brakes_the_arm_where_it_is_and_the_loop_recovers(tmp_path, ros_domain):
    """The default run: the paced world goes on braked while the sensor is frozen. On its return the sensor's stale
    backlog comes first; the controller must neither stop on a model coasted across the gap (it swung 1.36 rad) nor
    score the brake's hold as tracking."""
    out = tmp_path / "run"

    def freeze_the_sensor_twice(launcher):
        sensor = child_pid(launcher, "sensor_node")
        for _ in range(2):
            time.sleep(2.3)
            os.kill(sensor, signal.SIGSTOP)
            time.sleep(0.5)
            os.kill(sensor, signal.SIGCONT)

    code, output = run_while(out, freeze_the_sensor_twice, duration="9")
    assert code == 1, run_said(output)  # braked for a fault: never ok
    metrics = json.loads((out / "metrics.json").read_text())
    # A freeze the world took for the whole host's (the simulator stalled with the sensor: docs/controller.md, "Whose
    # time it was") pauses the world instead of braking: seen once in CI (1 brake, 3 host freezes). It is then
    # counted as a host freeze as long as the sensor's.
    paused = metrics["host_freeze_ms_max"] is not None and metrics["host_freeze_ms_max"] >= 400.0
    assert 2 - paused <= metrics["brake_engagements"] <= 2, metrics
    assert any(reason.startswith("the brakes held the arm") for reason in metrics["verdict_reasons"]), metrics
    assert metrics["tracking_max_rad"] <= 0.1, metrics["tracking_max_rad"]
    recording = report.read_recording(out / "bag")
    assert np.all(np.abs(recording.true_position) <= 1.1)
    assert np.max(np.abs(recording.true_effort)) < 10.0  # no full-torque kick on the way back


def test_estop_latches_until_released_and_the_loop_recovers(tmp_path, ros_domain):
    out = tmp_path / "run"

    def press_and_release(_run):
        time.sleep(3.0)
        engaged = cli("estop", timeout=60)
        assert engaged.returncode == 0, engaged.stdout + engaged.stderr
        assert "ENGAGED" in engaged.stdout and "simulator" in engaged.stdout
        time.sleep(2.0)
        released = cli("estop", "--release", timeout=60)
        assert released.returncode == 0, released.stdout + released.stderr

    code, output = run_while(out, press_and_release)
    assert code == 0, run_said(output)  # the e-stop was asked for: not the loop's fault
    assert "E-STOP" in output
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["brake_engagements_estop"] == metrics["brake_engagements"] >= 1, metrics
    # The ticks it held back (about 200) are not the loop's late efforts; a busy host's own are.
    assert metrics["late_efforts"] < 20, metrics["late_efforts"]
    recording = report.read_recording(out / "bag")
    status = recording.state["status"].astype(int)
    stopped = np.flatnonzero(status == state_layout.STATUS_CODES["stopped"])
    assert stopped.size > 50  # about 2 s of ticks without a command
    # Latched: the brakes held the arm still the whole time.
    t = recording.state["time_s"]
    during = (recording.true_time_s > t[stopped[0]] + 0.05) & (recording.true_time_s < t[stopped[-1]])
    assert np.ptp(recording.true_position[during, 0]) < 0.01
    assert np.all(
        recording.brakes[(recording.brakes_time_s > t[stopped[0]] + 0.05) & (recording.brakes_time_s < t[stopped[-1]])]
        > 0.5
    )
    # Released: re-acquired, then tracking again.
    after = status[stopped[-1] + 1 :]
    assert state_layout.STATUS_CODES["reacquiring"] in after.tolist()
    assert after[-1] == state_layout.STATUS_CODES["ok"]
    assert abs(recording.state["reference"][-1, 0] - recording.state["measured"][-1, 0]) < 0.01


def test_joint_names_that_disagree_end_the_run_fast_naming_both_sides(tmp_path, ros_domain):
    urdf = tmp_path / "renamed.urdf"
    urdf.write_text(resources.default_urdf().read_text().replace('name="joint1"', 'name="shoulder"'))
    config = tmp_path / "renamed.yaml"
    config.write_text(f"simulator:\n  ros__parameters:\n    urdf_path: {urdf}\n")
    started = time.monotonic()
    proc = cli("run", "--duration", "30", "--config", str(config), "--out", str(tmp_path / "run"), timeout=120)
    assert proc.returncode == 2
    assert time.monotonic() - started < 5  # the whole configuration is checked before anything starts
    assert "joint names differ" in proc.stderr and "shoulder" in proc.stderr and "joint1" in proc.stderr
    # Nodes started by hand, past that check: the controller itself ends it, naming both sides.
    from robot_controller import parameters as cfg

    params = cfg.load_stack()
    params["simulator"]["urdf_path"] = str(urdf)
    params_file = cfg.write_params_file(params, tmp_path / "params.yaml")
    nodes = [
        subprocess.Popen(
            [sys.executable, "-m", f"robot_controller.nodes.{name}", "--ros-args", "--params-file", str(params_file)],
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
        )
        for name in ("simulator", "sensor_node", "pid_controller")
    ]
    try:
        output = nodes[2].communicate(timeout=60)[0]
    finally:
        for node in nodes:
            node.kill()
            node.communicate()
    assert nodes[2].returncode != 0
    assert "joint names disagree" in output and "shoulder" in output and "joint1" in output


def test_a_killed_node_is_respawned_and_the_loop_recovers(tmp_path, ros_domain):
    out = tmp_path / "run"

    def kill_the_controller(run):
        time.sleep(2.0)
        controller = int(
            subprocess.run(
                ["pgrep", "-P", str(run.pid), "-f", "robot_controller.nodes.pid_controller"],
                capture_output=True,
                text=True,
            ).stdout.split()[0]
        )
        subprocess.run(["kill", "-KILL", str(controller)], check=True)

    code, output = run_while(out, kill_the_controller, "--respawn", duration="10")
    assert code == 1, run_said(output)  # the drive braked the arm for the fault: the run says so
    metrics = json.loads((out / "metrics.json").read_text())
    # Once for the kill; where the host froze the loop as well (on the wall clock, the loop's fault: the drive brakes
    # again, its defined reaction), once or more.
    held = "the brakes held the arm once for a fault" if not metrics.get("host_freezes") else "the brakes held the arm"
    assert held in output.splitlines()[-1], run_said(output)
    assert "pid_controller died (exit code -9): respawning" in output
    # Nothing of the run outlives it: the killed controller's designer process died with it (it was left behind).
    left = subprocess.run(["pgrep", "-f", str(out / "params.yaml")], capture_output=True, text=True).stdout.split()
    assert not left, subprocess.run(["ps", "-o", "pid,ppid,cmd", "-p", ",".join(left)], capture_output=True).stdout
    recording = report.read_recording(out / "bag")
    assert np.all(np.abs(recording.true_position[:, 0]) < 1.1)
    assert recording.state["status"][-1] == state_layout.STATUS_CODES["ok"]
    assert abs(recording.state["reference"][-1, 0] - recording.state["measured"][-1, 0]) < 0.01
