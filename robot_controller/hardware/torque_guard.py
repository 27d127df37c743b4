"""Our limits before the robot's: the torque a controller wants, made one the Franka's reflexes never have to refuse.

A real arm stops itself (a reflex) at its torque range, its torque rate (the FCI's 1,000 N·m/s on the commanded
torque), its joints' speed and position limits. A reflex ends the motion abruptly, so the guard keeps each torque
short of them: near a joint's speed limit it brakes the joint back under it, near a position limit it pushes the
joint back, then it clips the arm's total torque to its range and the commanded one's change to the rate. The robot
adds gravity itself (its own model): the guard is given gravity's torque, works on the total, and returns what the
robot is sent (total less gravity). No ROS, no libfranka: a pure function of its inputs and the last torque sent."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_controller.core.model.velocity_envelope import VelocityEnvelope

#: N·m/s: the FCI's limit on the commanded torque's rate (libfranka's ``kMaxTorqueRate``).
FRANKA_TORQUE_RATE_NM_S = 1000.0
#: Of the robot's torque rate limit, the controller's own slew limit: inside the guard's (gravity's own change, about
#: 30 N·m/s at 1 rad/s, adds to it), so that the guard's never cuts what the controller believes acts.
CONTROLLER_RATE_SHARE = 0.25


@dataclass(frozen=True)
class RobotLimits:
    """Per joint: the torque range (N·m, symmetric), the speed limit (rad/s), the position range (rad), a speed
    envelope near the position limits if the robot has one; and the commanded torque's rate limit (N·m/s, every
    joint)."""

    torque_nm: np.ndarray
    velocity_rad_s: np.ndarray
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    torque_rate_nm_s: float = FRANKA_TORQUE_RATE_NM_S
    envelope: VelocityEnvelope | None = None


@dataclass(frozen=True)
class GuardSettings:
    """How far inside the robot's limits the guard keeps, and how hard it acts."""

    torque_share: float = 0.98  #: of the torque range, at most (the robot's check is on the limit itself)
    #: of the torque rate limit, at most. When commands come late (a host's hiccup, the first ticks) the robot can skip
    #: some and judge the next against the last it took, over one period: ramping at 95 % of the limit, two skipped
    #: made a 1.27 N·m step the robot refused (controller_torque_discontinuity). At 30 % two may be skipped. (The
    #: controller is given a slew limit inside this, :data:`CONTROLLER_RATE_SHARE`, so that what it computes is what
    #: acts: a guard that cut its torque unseen wound its observer up into a 2.7 rad/s swing.)
    rate_share: float = 0.3
    velocity_share: float = 0.85  #: no joint is let past this share of its speed limit
    position_margin_rad: float = 0.1  #: no joint is let closer than this to a position limit
    braking_share: float = 0.5  #: of the torque range, what the guard counts on to stop a joint (gravity takes some)
    braking_nms: float = 20.0  #: N·m per rad/s a joint is headed past its speed share
    stiffness_nm_rad: float = 200.0  #: N·m per rad inside the position margin
    damping_nms: float = 10.0  #: N·m per rad/s towards the limit, inside the margin


def stopping_distance(
    speed: np.ndarray, push_nm: np.ndarray, rate_nm_s: float, brake_nm: np.ndarray, inertia_kgm2: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Per joint, moving at ``speed`` (rad/s) with ``push_nm`` along its motion, the torque ramped down at
    ``rate_nm_s`` to ``-brake_nm`` and held there: how far it goes before it stops (rad), and the fastest it goes
    (rad/s). One joint alone (no coupling): the robot cancels gravity, so the torque sent is what accelerates it."""
    rate, inertia = rate_nm_s, inertia_kgm2
    ramp_s = np.maximum(push_nm + brake_nm, 0.0) / rate  # until the full brake
    peak = speed + np.maximum(push_nm, 0.0) ** 2 / (2.0 * rate * inertia)  # the push ramping down to 0
    # r·t²/2 − push·t − speed·I = 0: stopped during the ramp if this comes before its end
    stop_s = (push_nm + np.sqrt(push_nm**2 + 2.0 * rate * speed * inertia)) / rate

    def travelled(t: np.ndarray) -> np.ndarray:
        return speed * t + (push_nm * t**2 / 2.0 - rate * t**3 / 6.0) / inertia

    at_full_brake = speed + (push_nm * ramp_s - rate * ramp_s**2 / 2.0) / inertia
    braked = travelled(ramp_s) + np.maximum(at_full_brake, 0.0) ** 2 * inertia / (2.0 * brake_nm)
    return np.where(stop_s <= ramp_s, travelled(stop_s), braked), peak


class TorqueGuard:
    """``guard(total_nm, gravity_nm, position, velocity, inertia_kgm2)`` → the torque to send the robot (gravity left
    out), within :class:`RobotLimits` by :class:`GuardSettings`. The torque's rate limit means a push cannot be taken
    back at once: the guard acts when a joint *would* pass its speed share or its position margin once the push is
    ramped down (:func:`stopping_distance`), not when it has. ``last_sent`` is where the rate limit starts from (zero
    at first: torque control starts from nothing commanded)."""

    def __init__(self, limits: RobotLimits, period_s: float, settings: GuardSettings | None = None) -> None:
        self.limits = limits
        self.settings = settings = settings or GuardSettings()
        self.max_step_nm = settings.rate_share * limits.torque_rate_nm_s * period_s
        self.rate_nm_s = self.max_step_nm / period_s
        self.max_torque_nm = settings.torque_share * limits.torque_nm
        self.brake_nm = settings.braking_share * limits.torque_nm
        self.allowed_rad_s = settings.velocity_share * limits.velocity_rad_s
        self.lowest_rad = limits.lower_rad + settings.position_margin_rad
        self.highest_rad = limits.upper_rad - settings.position_margin_rad
        self.last_sent = np.zeros(limits.torque_nm.size)
        self.acted = np.zeros(limits.torque_nm.size, dtype=int)  #: per joint, the ticks the guard changed the torque
        #: per joint, whether the last tick braked it (headed past its speed share or into its position margin)
        self.braking = np.zeros(limits.torque_nm.size, dtype=bool)

    def __call__(
        self,
        total_nm: np.ndarray,
        gravity_nm: np.ndarray,
        position: np.ndarray,
        velocity: np.ndarray,
        inertia_kgm2: np.ndarray,
        taken_nm: np.ndarray | None = None,
    ) -> np.ndarray:
        """:param taken_nm: the command the robot says it last took (libfranka's ``tau_J_d``; None: the last sent).
        The robot judges a command's rate against the last it took: the last sent or, its state being a period
        behind, the one before (or older, when late commands were skipped). So each command is kept within a step of
        the last sent and two of the last taken. (Within one step of the last taken alone, the torque rose at half
        the rate the controller counted on: the arm lagged 120 mrad and swung.)"""
        settings = self.settings
        wanted = np.where(np.isfinite(total_nm), total_nm, gravity_nm)  # nothing to follow: hold gravity alone
        net = wanted - gravity_nm  # what accelerates each joint: the robot adds gravity back
        moving = np.abs(velocity) > 1e-6
        along = np.where(moving, np.sign(velocity), np.sign(self.last_sent))  # the way each joint goes (or is pushed)
        speed = np.abs(velocity)
        distance, peak = stopping_distance(speed, along * self.last_sent, self.rate_nm_s, self.brake_nm, inertia_kgm2)
        allowed = self.allowed_rad_s
        if self.limits.envelope is not None:  # the speed it may have where it would stop, the way it goes
            # (all of it: the robot allows 0.1 rad/s past it, and trajectories keep within two thirds of it)
            towards_lower, towards_upper = self.limits.envelope.speeds(position + along * distance)
            allowed = np.minimum(allowed, np.where(along > 0, towards_upper, towards_lower))
        # Headed past its speed share: nothing pushes it on, and it is braked.
        fast = peak > allowed
        if fast.any():
            brake = -settings.braking_nms * (peak[fast] - allowed[fast])
            net[fast] = along[fast] * np.minimum(along[fast] * net[fast], brake)
        # Headed inside its position margin: braked with all the guard counts on.
        room = np.where(along > 0, self.highest_rad - position, position - self.lowest_rad)
        closing = (along != 0) & (distance >= room)
        if closing.any():
            net[closing] = along[closing] * np.minimum(along[closing] * net[closing], -self.brake_nm[closing])
        # Inside the margin all the same: a spring and a damper push it back out.
        below, above = position - self.lowest_rad, position - self.highest_rad
        low, high = below < 0.0, above > 0.0
        self.braking = fast | closing | low | high
        k, c = settings.stiffness_nm_rad, settings.damping_nms
        if low.any():
            net[low] -= k * below[low] + c * np.minimum(velocity[low], 0.0)
        if high.any():
            net[high] -= k * above[high] + c * np.maximum(velocity[high], 0.0)
        total = np.clip(net + gravity_nm, -self.max_torque_nm, self.max_torque_nm)
        floor_nm, ceiling_nm = self.last_sent - self.max_step_nm, self.last_sent + self.max_step_nm
        if taken_nm is not None:
            floor_nm = np.maximum(floor_nm, taken_nm - 2.0 * self.max_step_nm)
            ceiling_nm = np.minimum(ceiling_nm, taken_nm + 2.0 * self.max_step_nm)
            behind = floor_nm > ceiling_nm  # the robot far behind what was sent: from what it took
            floor_nm = np.where(behind, taken_nm - self.max_step_nm, floor_nm)
            ceiling_nm = np.where(behind, taken_nm + self.max_step_nm, ceiling_nm)
        sent = np.clip(total - gravity_nm, floor_nm, ceiling_nm)
        self.acted += np.abs(sent + gravity_nm - wanted) > 1e-9
        self.last_sent = sent
        return sent
