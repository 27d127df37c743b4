"""Speed limits that close in near a joint's position limits, as a robot's own safety checks them: libfranka's
``JointVelocityLimitsConfig`` (the FR3's, from ``<position_based_velocity_limits>`` in franka_description's fr3.urdf,
which franka-sim enforces too). Towards its upper limit a joint may go ``min(max, max(0, sqrt(2·deceleration·(upper −
q)) − offset))`` rad/s, and the mirror towards its lower: the speed from which it can still stop there."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class VelocityEnvelope:
    """Per joint: the top speed (rad/s), the offset (rad/s), the deceleration (rad/s²) and the position range (rad)."""

    max_rad_s: np.ndarray
    offset_rad_s: np.ndarray
    deceleration_rad_s2: np.ndarray
    lower_rad: np.ndarray
    upper_rad: np.ndarray

    def speeds(self, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The speed (rad/s, ≥ 0) each joint may have towards its lower and towards its upper limit at ``position``
        (any shape ending in the joints)."""
        ramp_up = np.sqrt(np.maximum(0.0, 2.0 * self.deceleration_rad_s2 * (self.upper_rad - position)))
        ramp_down = np.sqrt(np.maximum(0.0, 2.0 * self.deceleration_rad_s2 * (position - self.lower_rad)))
        towards_upper = np.minimum(self.max_rad_s, np.maximum(0.0, ramp_up - self.offset_rad_s))
        towards_lower = np.minimum(self.max_rad_s, np.maximum(0.0, ramp_down - self.offset_rad_s))
        return towards_lower, towards_upper

    def limit(self, position: np.ndarray, velocity: np.ndarray) -> np.ndarray:
        """The speed each joint may have at ``position`` the way ``velocity`` goes (rad/s, ≥ 0)."""
        towards_lower, towards_upper = self.speeds(position)
        return np.where(velocity >= 0.0, towards_upper, towards_lower)


#: The FR3: the arm libfranka 0.21 drives (franka-sim stands in for it). Near its limits the elbow may go 1.5 rad/s,
#: not 2.6.
FR3_VELOCITY_ENVELOPE = VelocityEnvelope(
    max_rad_s=np.array([2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26]),
    offset_rad_s=np.array([0.3, 0.2, 0.2, 0.3, 0.35, 0.35, 0.35]),
    deceleration_rad_s2=np.array([6.0, 2.585, 3.5, 4.0, 17.0, 5.5, 17.0]),
    lower_rad=np.array([-2.7501, -1.7918, -2.9065, -3.0481, -2.8101, 0.54092, -3.0196]),
    upper_rad=np.array([2.7501, 1.7918, 2.9065, -0.1458, 2.8101, 4.5205, 3.0196]),
)

#: by the name the ``velocity_envelope`` parameter gives
ENVELOPES = {"fr3": FR3_VELOCITY_ENVELOPE}


def position_range(limits, params) -> tuple[np.ndarray, np.ndarray]:
    """The position range a trajectory keeps to: ``limits``' (the URDF's), within the envelope's that ``params``'
    ``velocity_envelope`` names, if any (a robot's own range, which its reflexes judge by)."""
    envelope = ENVELOPES.get(params["velocity_envelope"])
    if envelope is None:
        return limits.lower, limits.upper
    return np.maximum(limits.lower, envelope.lower_rad), np.minimum(limits.upper, envelope.upper_rad)
