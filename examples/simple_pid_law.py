"""A control law built on the simple-pid package: one ``simple_pid.PID`` per joint,
plus the torque that holds the arm up against gravity (from the arm model).

    pip install simple-pid          # or: pip install -e '.[examples]'
    robot-controller step --controller examples/simple_pid_law.py:SimplePidLaw
    robot-controller tune --controller examples/simple_pid_law.py:SimplePidLaw --quick

The framework calls ``update`` once per control period with the estimated state and
the reference at the tick; it clips the torque to the limit and handles timing, the
watchdog and stops. See examples/own_controller.py for the smallest law.

The gains are in N·m per rad, for the reference arm (0.083 kg·m²): the defaults are
near what ``tune --controller`` chose there (Kp 36.3, Ki 629, Kd 3.28, with less room at half
the drive's gain), and keep the loop stable with the readings two control periods late
(2.1 mrad RMS on the sine, in process). Stiffer gains track
closer (Kp 200, Ki 100, Kd 8: 1.4 mrad) but not one period late. Another arm needs
its own: one per joint (``law.kp: [..]``), or tune them.
"""

import numpy as np
from simple_pid import PID

from robot_controller.core.laws import ControlLaw, Parameter


class SimplePidLaw(ControlLaw):
    """τ = PID(q_ref − q) + g(q) + J·q̈_ref, per joint, with simple-pid's PID."""

    # Each becomes the ROS parameter law.NAME (one value for every joint, or a list of one per joint).
    # gain=True: `robot-controller tune --controller ...` searches it between minimum and maximum.
    parameters = (
        Parameter("kp", 36.0, "proportional gain, N·m/rad", 0.0, 2000.0, per_joint=True, gain=True),
        Parameter("ki", 400.0, "integral gain, N·m/(rad·s)", 0.0, 5000.0, per_joint=True, gain=True),
        Parameter("kd", 3.3, "derivative gain, N·m·s/rad", 0.0, 100.0, per_joint=True, gain=True),
        Parameter("acceleration_feedforward", True, "add each joint's inertia × the reference's acceleration"),
    )

    def __init__(self, arm, period_s, params):
        super().__init__(arm, period_s, params)
        limit = arm.torque_limit  # N·m per joint: the integral is kept within it (simple-pid's anti-windup)
        self.pids = [
            PID(
                sample_time=None,  # compute on every call: the framework calls once per period
                output_limits=(-limit[j], limit[j]),
                differential_on_measurement=False,  # D on the error: it sees the reference's velocity too
                time_fn=lambda: 0.0,  # never read: every call passes dt
            )
            for j in range(arm.joint_count)
        ]
        self._apply_gains()
        # Each joint's own inertia at the home pose (the diagonal of M(q)), for the feedforward.
        self.inertia = np.diag(arm.mass_matrix(np.zeros(arm.joint_count))).copy()
        self.feedforward = np.zeros(arm.joint_count)

    def _apply_gains(self):
        for j, pid in enumerate(self.pids):
            pid.tunings = (self.params["kp"][j], self.params["ki"][j], self.params["kd"][j])

    def set_params(self, params):
        super().set_params(params)
        self._apply_gains()  # bumpless: simple-pid keeps its integral in N·m

    def reset(self, state):
        for pid in self.pids:
            pid.reset()  # forget the integral and the last error

    def update(self, time_s, state, reference):
        feedback = np.zeros(self.arm.joint_count)
        for j, pid in enumerate(self.pids):
            pid.setpoint = reference.position[j]
            feedback[j] = pid(state.position[j], dt=self.period_s)  # simple-pid takes the measurement
        feedforward = self.arm.gravity(state.position)  # N·m that hold the arm still where it is
        if self.params["acceleration_feedforward"]:
            feedforward = feedforward + self.inertia * reference.acceleration
        self.feedforward = feedforward
        return feedback + feedforward

    def terms(self):
        # Shown in /controller/state's p, i, d and feedforward blocks.
        p, i, d = (np.array([pid.components[k] for pid in self.pids]) for k in range(3))
        return {"p": p, "i": i, "d": d, "feedforward": self.feedforward}
