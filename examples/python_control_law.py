"""A control law designed with python-control: discrete LQR gains from ``control.dlqr``,
computed once in ``__init__`` (and again when a weight changes), applied through the
arm's inverse dynamics (computed torque).

    pip install control             # or: pip install -e '.[examples]'
    robot-controller step --controller examples/python_control_law.py:LqrComputedTorque
    robot-controller tune --controller examples/python_control_law.py:LqrComputedTorque --quick

The design: the inverse dynamics τ = M(q)·a + c(q, q̇) + g(q) turns every joint into a
double integrator q̈ = a, whatever the arm. On that, with the state x = [∫e, e, ė]
(e = q − q_ref), python-control designs the discrete LQR a = q̈_ref − K·x that minimises
Σ xᵀQx + a², at the control period. The gains come out in rad/s² per rad, so one design
serves every joint of a chain, light or heavy. The default weights track the sine to
1.0 mrad RMS (in process) and keep the loop stable with the readings two control periods
late, as ``tune --controller`` requires; ten times heavier ones track 0.95 mrad, barely.
"""

import control
import numpy as np

from robot_controller.core.laws import ControlLaw, Parameter


class LqrComputedTorque(ControlLaw):
    """Computed torque with discrete LQR gains on [∫e, e, ė], designed with ``control.dlqr``."""

    # The LQR's state weights (the weight on the acceleration is 1: only the ratio matters).
    # gain=True: `robot-controller tune --controller ...` searches them (log-scaled: each spans decades).
    parameters = (
        Parameter("q_integral", 3.0e6, "weight on ∫e, 1/s⁶", 1.0, 1.0e10, gain=True),
        Parameter("q_position", 3.0e5, "weight on e, 1/s⁴", 1.0, 1.0e10, gain=True),
        Parameter("q_velocity", 1.0e3, "weight on ė, 1/s²", 1.0e-2, 1.0e7, gain=True),
        Parameter("cancel_disturbance", True, "subtract the disturbance observer's torque estimate"),
    )
    # Extra per-joint terms for /controller/state (besides p, i, d and feedforward).
    state_terms = ("integral",)

    def __init__(self, arm, period_s, params):
        super().__init__(arm, period_s, params)
        self.gains = self.design()
        self.integral = np.zeros(arm.joint_count)  # ∫e, rad·s
        self._terms = {}

    def design(self):
        """K (1 × 3): the discrete LQR on the double integrator, sampled with a zero-order hold."""
        a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])  # d/dt [∫e, e, ė]
        b = np.array([[0.0], [0.0], [1.0]])  # the acceleration a drives ë
        plant = control.c2d(control.ss(a, b, np.eye(3), np.zeros((3, 1))), self.period_s)
        q = np.diag([self.params["q_integral"], self.params["q_position"], self.params["q_velocity"]])
        gains, _, poles = control.dlqr(plant.A, plant.B, q, np.eye(1))
        if np.max(np.abs(poles)) >= 1.0:  # a law that refuses to start says why, in one line
            raise ValueError(f"the LQR design is not stable (poles {np.abs(poles).round(3).tolist()})")
        return np.asarray(gains)[0]

    def set_params(self, params):
        super().set_params(params)
        self.gains = self.design()  # the integral is kept: the change is bumpless up to the new Ki

    def reset(self, state):
        self.integral[:] = 0.0

    def update(self, time_s, state, reference):
        error = state.position - reference.position  # rad
        error_rate = state.velocity - reference.velocity  # rad/s
        integral = self.integral + error * self.period_s
        k_i, k_p, k_d = self.gains
        acceleration = reference.acceleration - (k_i * integral + k_p * error + k_d * error_rate)
        # The torque that gives that acceleration on this arm, where it is now.
        torque = self.arm.inverse_dynamics(state.position, state.velocity, acceleration)
        if self.params["cancel_disturbance"]:
            torque = torque - state.disturbance  # the observer's estimate of an external push
        # Anti-windup: integrate only while the torque is within the limit.
        within = np.abs(torque) < self.arm.torque_limit
        self.integral = np.where(within, integral, self.integral)
        inertia = np.diag(self.arm.mass_matrix(state.position))  # each joint's own, for the terms in N·m
        self._terms = {
            "p": -inertia * k_p * error,
            "i": -inertia * k_i * self.integral,
            "d": -inertia * k_d * error_rate,
            "integral": self.integral.copy(),
        }
        self._terms["feedforward"] = torque - self._terms["p"] - self._terms["i"] - self._terms["d"]
        return torque

    def terms(self):
        return self._terms
