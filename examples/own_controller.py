"""Write your own control law: a PD law with gravity compensation.

Name it in pid_controller's ``controller_type`` as ``/path/to/examples/own_controller.py:PDWithGravity``
(docs/own-controller.md). The framework gives it the estimated state and the reference each tick,
and keeps the rest: timing, the watchdog, the torque limit, controlled stops.
"""

import numpy as np

from robot_controller.core.laws import ControlLaw, Parameter


class PDWithGravity(ControlLaw):
    """τ = M(q)·(q̈_ref + ωₙ²·e + 2ζωₙ·ė) + g(q): a PD on each joint's own inertia, plus gravity."""

    # Declared parameters become ROS parameters law.natural_frequency_hz and law.damping_ratio.
    parameters = (
        # 4 Hz keeps the loop stable with two control periods of delay nobody accounts for.
        Parameter("natural_frequency_hz", 4.0, "closed-loop bandwidth of each joint, Hz", 0.5, 30.0, gain=True),
        Parameter("damping_ratio", 1.0, "closed-loop damping ratio", 0.3, 3.0, gain=True),
    )

    def update(self, time_s, state, reference):
        omega = 2 * np.pi * self.params["natural_frequency_hz"]  # rad/s
        zeta = self.params["damping_ratio"]
        error = reference.position - state.position  # rad
        error_rate = reference.velocity - state.velocity  # rad/s
        # The acceleration each joint should have, then the torque that gives it on this arm.
        acceleration = reference.acceleration + omega**2 * error + 2 * zeta * omega * error_rate
        inertia = self.arm.mass_matrix(state.position)  # kg·m², couples the joints of a chain
        return inertia @ acceleration + self.arm.gravity(state.position)
