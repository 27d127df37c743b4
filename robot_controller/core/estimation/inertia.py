"""The inertia each joint has beyond its arm model (a geared motor's rotor: armature), estimated while the arm moves
from what the disturbance observer sees (:class:`InertiaEstimate`).

A joint heavier than its model by δ accelerates less than the model says, and the observer explains the difference
as an external torque ``d = −δ·a`` on that joint's own axis. Along the sine the arm follows, ``a`` is proportional to
the position, so a gravity torque the model has wrong looks just like an inertia: only the faster part of the motion
(the loop's own corrections, and an oscillation if the model is far enough off to cause one) tells them apart. The
fit is therefore a least-squares one of the observer's torque on the acceleration (and on the sign of the velocity,
friction's reversals) with their slow parts taken away; it moves only while the joint's readings disagree with the
filter, so an arm that agrees with its model is never touched."""

from __future__ import annotations

import numpy as np

#: s, the time constant of the slow part taken away (the trajectory's 0.25 Hz and gravity's changes)
HIGHPASS_S = 0.2
#: s, over about how long the fit's sums are averaged
WINDOW_S = 0.5
#: s, how fast the estimate follows the fit (a jumpy estimate would move the loop's gains with it)
ADAPT_S = 1.0
#: rad/s, the speed over which friction's sign turns (tanh(v / FRICTION_SPEED))
FRICTION_SPEED = 0.02
#: rad²/s⁴, the least mean square of the fast acceleration a fit is taken from (below it: too little motion)
MIN_EXCITATION = 1e-4
#: a reading further apart than this from the last, s, starts the signals again (a fault, a restart)
MAX_GAP_S = 0.1
#: s, how long the signals run before the fit moves anything: the filter's first readings, before it has seen
#: whether they agree, disagree by design, and the averages are not yet averages (1.3 % on planar2's shoulder,
#: learnt in its first 80 ms, left 5 mrad on its elbow)
SETTLE_S = 1.0
#: kg·m², the most added to a joint
MAX_EXTRA_KGM2 = 1.0
#: a fit within this share of the joint's own inertia moves nothing: readings late by more than their stamps say look
#: heavier too (20 ms unstamped on the reference arm: 20 %), and gains raised for them would take the delay margin
DEAD_ZONE = 0.5


class InertiaEstimate:
    """Per joint, the inertia (kg·m²; kg on a slide) the arm has beyond its model, at least 0: the model's can be
    raised (a rotor added), never lowered below the URDF's links.

    :param own_inertia: kg·m² per joint, the model's own (what the dead zone is a share of)
    """

    def __init__(self, own_inertia: np.ndarray) -> None:
        self._dead_zone = DEAD_ZONE * np.asarray(own_inertia, dtype=float)
        joint_count = len(self._dead_zone)
        self.extra = np.zeros(joint_count)  #: kg·m² per joint, the estimate
        self._last: tuple[float, np.ndarray] | None = None  #: (time s, velocity) of the last reading
        self._slow: np.ndarray | None = None  #: (n, 3): the slow parts of acceleration, friction's sign, torque
        self._since_s = 0.0  #: when the signals started
        self._aa = np.zeros((joint_count, 3))  #: per joint, averaged a², a·s, s² (the fast parts)
        self._ad = np.zeros((joint_count, 2))  #: per joint, averaged a·d, s·d

    def restart(self) -> None:
        """Forget the signals (the estimate stays): after a fault the next readings start them again."""
        self._last = self._slow = None

    def update(self, time_s: float, velocity: np.ndarray, torque: np.ndarray, disagreeing: np.ndarray) -> np.ndarray:
        """Take the filter's velocity (rad/s) and the observer's torque on each joint's own axis (N·m) after a
        reading at ``time_s``; ``disagreeing`` per joint: its readings disagree with the filter. Returns ``extra``."""
        velocity = np.asarray(velocity, dtype=float)
        last, self._last = self._last, (time_s, velocity.copy())
        if last is None or not 0.0 < time_s - last[0] < MAX_GAP_S:
            self._slow = None
            return self.extra
        dt = time_s - last[0]
        signals = np.column_stack([(velocity - last[1]) / dt, np.tanh(velocity / FRICTION_SPEED), torque])
        if self._slow is None:
            self._slow, self._since_s = signals.copy(), time_s
        self._slow += min(1.0, dt / HIGHPASS_S) * (signals - self._slow)
        a, s, d = (signals - self._slow).T
        w = min(1.0, dt / WINDOW_S)
        self._aa += w * (np.column_stack([a * a, a * s, s * s]) - self._aa)
        self._ad += w * (np.column_stack([a * d, s * d]) - self._ad)
        # d = −δ·a − f·s: the 2 × 2 normal equations per joint (a little ridge keeps a still joint's solvable).
        aa, a_s, ss = self._aa[:, 0] + 1e-6, self._aa[:, 1], self._aa[:, 2] + 1e-6
        beyond = -(ss * self._ad[:, 0] - a_s * self._ad[:, 1]) / (aa * ss - a_s * a_s)
        moving = np.asarray(disagreeing, dtype=bool) & (self._aa[:, 0] > MIN_EXCITATION)
        moving &= np.abs(beyond) > self._dead_zone
        if time_s - self._since_s < SETTLE_S:
            return self.extra
        step = np.where(moving, (dt / ADAPT_S) * beyond, 0.0)
        self.extra = np.clip(self.extra + step, 0.0, MAX_EXTRA_KGM2)
        return self.extra
