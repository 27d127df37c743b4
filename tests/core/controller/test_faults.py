"""What the controller does when an input is lost and when it returns (no ROS):
controlled stop on the model, torque off after the timeout, a blend back onto
the trajectory with no jump, and the same after its own pause or an e-stop."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.controller import JointController, Status
from robot_controller.core.controller.safe_motion import Blend, ControlledStop
from robot_controller.core.model import ArmDynamics, MujocoPlant
from robot_controller.core.reference import make_trajectory

PERIOD = 0.01


def test_a_controlled_stop_decelerates_to_rest_and_holds():
    stop = ControlledStop(1.0, np.array([0.2]), np.array([2.0]), 20.0)
    q, v, a = stop.at(1.0)
    assert q[0] == pytest.approx(0.2) and v[0] == pytest.approx(2.0) and a[0] == pytest.approx(-20.0)
    q, v, a = stop.at(1.1)  # v²/(2a) = 0.1 rad later, at rest
    assert q[0] == pytest.approx(0.3) and v[0] == 0.0 and a[0] == 0.0
    assert stop.at(5.0)[0][0] == pytest.approx(0.3) and stop.at_rest(1.1) and not stop.at_rest(1.05)


def test_a_blend_starts_at_the_offset_ends_at_zero_within_its_acceleration():
    blend = Blend.starting(0.0, np.array([0.8]), np.array([-1.5]), max_acceleration=20.0)
    p, v, _ = blend.offset_at(0.0)
    assert p[0] == pytest.approx(0.8) and v[0] == pytest.approx(-1.5)
    p, v, a = blend.offset_at(blend.duration_s)
    assert abs(p[0]) < 1e-12 and abs(v[0]) < 1e-12 and abs(a[0]) < 1e-9 and blend.done(blend.duration_s)
    peak = max(abs(blend.offset_at(t)[2][0]) for t in np.linspace(0, blend.duration_s, 400))
    assert peak <= 20.0 + 1e-9


class Loop:
    """The default controller on the MuJoCo arm, readings delivered unless told not to."""

    def __init__(self, lockstep: bool = False) -> None:
        params = cfg.load_stack()["pid_controller"] | {"lockstep": lockstep}
        dynamics = ArmDynamics(resources.default_urdf())
        self.controller = JointController(cfg.controller_config(params, 1), 1, dynamics)
        self.plant = MujocoPlant(resources.default_urdf(), 0.001)
        self.plant.reset(np.zeros(1))
        self.trajectory = make_trajectory("sine", joint_count=1)
        self.t = 0.0
        self.log: list[tuple[float, Status, float, float, float]] = []  # t, status, reference, true, command

    def run(self, seconds: float, readings: bool = True, controller_runs: bool = True) -> None:
        for _ in range(int(round(seconds / PERIOD))):
            self.controller.set_reference(self.t, *self.trajectory.sample(self.t), sample_time_s=self.t)
            q, v = self.plant.state()
            if readings:
                self.controller.set_measurement(self.t, self.t, q, v)
            command = np.zeros(1)
            if controller_runs:
                out = self.controller.update(self.t)
                command = out.command if out.status.commanding else np.zeros(1)
                self.log.append((self.t, out.status, out.reference[0], q[0], command[0]))
            self.plant.step(command, 10)
            self.t += PERIOD

    def statuses(self, since: float = 0.0) -> list[Status]:
        seen: list[Status] = []
        for t, status, *_ in self.log:
            if t >= since and (not seen or seen[-1] is not status):
                seen.append(status)
        return seen


def test_lost_readings_give_a_controlled_stop_on_the_model_then_a_smooth_return():
    loop = Loop()
    loop.run(3.0)  # t = 3 s: the sine at peak speed
    loop.run(0.5, readings=False)
    lost_at = 3.0
    loop.run(3.0)
    during = [row for row in loop.log if lost_at <= row[0] < lost_at + 0.5]
    assert Status.WATCHDOG in {row[1] for row in during}
    # The stop reference comes to rest, the arm (driven on the model alone) stays with it.
    stop_rows = [row for row in during if row[1] is Status.WATCHDOG]
    assert abs(stop_rows[-1][2] - stop_rows[-2][2]) < 1e-9  # at rest
    assert max(abs(row[2] - row[3]) for row in stop_rows) < 0.02
    assert all(abs(row[4]) <= 10.0 for row in loop.log)
    assert loop.statuses(lost_at)[-2:] == [Status.REACQUIRING, Status.OK]
    # No jump: the first re-acquiring reference is where the arm was.
    first = next(row for row in loop.log if row[1] is Status.REACQUIRING)
    assert abs(first[2] - first[3]) < 0.01
    assert abs(loop.log[-1][2] - loop.log[-1][3]) < 0.005


def test_a_stale_reading_after_a_sensor_pause_is_refused_not_acted_on():
    # A paused sensor's first sample after SIGCONT can be the one it held when
    # it stopped: stamped 0.5 s ago, at full speed. Acted on, it swung the arm.
    loop = Loop()
    loop.run(3.0)
    stale_stamp = loop.t
    stale_q, stale_v = loop.plant.state()
    loop.run(0.5, readings=False)
    reason = loop.controller.set_measurement(stale_stamp, loop.t, stale_q, stale_v)
    assert reason is not None and "old" in reason
    # Still no sign of life: the stop on the model has come to rest, the brake holds.
    assert loop.controller.update(loop.t).status is Status.SENSOR_LOST
    resumed_at = loop.t
    loop.run(3.0)
    after = [row for row in loop.log if row[0] >= resumed_at]
    assert after[0][1] is Status.REACQUIRING and abs(after[0][2] - after[0][3]) < 0.01
    assert max(abs(row[4]) for row in after) < 10.0  # no saturation on the way back
    future = loop.controller.set_measurement(loop.t + 5.0, loop.t, stale_q, stale_v)
    assert future is not None and "future" in future


def test_readings_missing_past_the_timeout_stop_commanding():
    loop = Loop()
    loop.run(2.0)
    loop.run(1.5, readings=False)
    assert loop.log[-1][1] is Status.SENSOR_LOST and not Status.SENSOR_LOST.commanding


def test_after_its_own_pause_the_controller_reacquires_instead_of_jumping():
    loop = Loop()
    loop.run(3.0)
    loop.plant.set_brakes(np.array([True]), 50.0)  # what the drive does when commands stop
    loop.run(0.5, controller_runs=False)
    loop.plant.set_brakes(np.array([False]), 50.0)
    loop.run(3.0)
    assert loop.statuses(3.0)[:2] == [Status.REACQUIRING, Status.OK]
    first = next(row for row in loop.log if row[0] >= 3.0)
    assert abs(first[2] - first[3]) < 0.01  # the reference starts where the braked arm is
    assert max(abs(row[4]) for row in loop.log if row[0] >= 3.0) < 10.0  # no saturation on the way back


def test_a_pause_that_ends_before_the_reference_is_fresh_holds_where_the_arm_is():
    # The controller resumes; its first tick comes before the planner's queued
    # sample: it must hold the arm where it is now, not where it held it at start.
    loop = Loop()
    loop.run(3.5)  # the sine at its peak, far from where the loop started
    loop.plant.set_brakes(np.array([True]), 50.0)
    loop.plant.step(np.zeros(1), 500)  # 0.5 s: the controller (and, as it sees it, the planner) silent
    loop.t += 0.5
    loop.plant.set_brakes(np.array([False]), 50.0)
    q, v = loop.plant.state()
    loop.controller.set_measurement(loop.t, loop.t, q, v)
    first = loop.controller.update(loop.t)  # the reference is 0.5 s old
    assert first.status is Status.REACQUIRING
    assert abs(first.reference[0] - q[0]) < 0.01 and abs(first.command[0]) < 10.0
    loop.run(3.0)
    assert max(abs(row[4]) for row in loop.log if row[0] >= 3.5) < 10.0


def test_a_machine_wide_stall_of_70_ms_is_no_sensor_loss():
    # Everything stops at once (the host took the CPUs): the arm goes on under the
    # last torque, no reading and no tick for 70 ms. The controller's first tick
    # after it, before any reading, must not take that for a lost sensor.
    loop = Loop()
    loop.run(3.0)
    last_command = np.array([loop.log[-1][4]])
    loop.plant.step(last_command, 70)
    loop.t += 0.07
    first = loop.controller.update(loop.t)
    assert first.status is Status.REACQUIRING and abs(first.command[0]) < 10.0
    loop.run(2.0)
    assert max(abs(row[4]) for row in loop.log if row[0] >= 3.0) < 10.0
    assert Status.WATCHDOG not in {row[1] for row in loop.log}


def test_an_estop_stops_commanding_until_released_then_reacquires():
    loop = Loop()
    loop.run(2.0)
    loop.controller.halt(True)
    loop.plant.set_brakes(np.array([True]), 50.0)
    loop.run(0.5)
    assert loop.log[-1][1] is Status.STOPPED and not Status.STOPPED.commanding
    loop.controller.halt(False)
    loop.plant.set_brakes(np.array([False]), 50.0)
    loop.run(3.0)
    assert loop.statuses(2.5) == [Status.REACQUIRING, Status.OK]


def test_a_silent_planner_gives_a_controlled_stop_then_a_blend_back():
    loop = Loop()
    loop.run(3.0)
    trajectory = loop.trajectory
    loop.trajectory = None
    for _ in range(50):  # 0.5 s with readings but no reference samples
        q, v = loop.plant.state()
        loop.controller.set_measurement(loop.t, loop.t, q, v)
        out = loop.controller.update(loop.t)
        loop.log.append((loop.t, out.status, out.reference[0], q[0], out.command[0]))
        loop.plant.step(out.command, 10)
        loop.t += PERIOD
    loop.trajectory = trajectory
    loop.run(3.0)
    assert loop.statuses(3.0) == [Status.OK, Status.REFERENCE_LOST, Status.REACQUIRING, Status.OK]
    references = np.array([row[2] for row in loop.log])
    assert np.max(np.abs(np.diff(references))) < 0.05  # never a jump (the sine moves ≤ 0.031 per tick)


def test_in_a_paced_world_that_went_on_braked_the_controller_neither_stops_on_its_model_nor_commands_until_a_reading():
    # The paced world waits for each tick's command and goes on only with its drive's brakes on: a sensor frozen
    # 0.46 s brakes the arm where it is. The controller's first tick after it came on the sensor's stale backlog: a
    # stop on its model, coasted 0.46 s as if the arm were free, commanded 10 N·m towards -1.3 rad (the arm stood
    # at 0.55), and the next tick -10 N·m.
    loop = Loop(lockstep=True)
    loop.run(2.8)
    stale_stamp = loop.t
    stale_q, stale_v = loop.plant.state()
    loop.plant.set_brakes(np.array([True]), 50.0)
    loop.run(0.46, readings=False, controller_runs=False)
    loop.plant.set_brakes(np.array([False]), 50.0)
    assert loop.controller.set_measurement(stale_stamp, loop.t, stale_q, stale_v) is not None  # refused: too old
    out = loop.controller.update(loop.t)
    assert not out.status.commanding, out.status  # the brakes hold the arm: nothing to stop, no command
    resumed_at = loop.t
    loop.run(2.0)
    after = [row for row in loop.log if row[0] > resumed_at]
    assert after[0][1] is Status.REACQUIRING and abs(after[0][2] - after[0][3]) < 0.01  # from where it stood
    assert max(abs(row[4]) for row in after) < 10.0  # no saturation on the way back
    assert Status.WATCHDOG not in {row[1] for row in after}
