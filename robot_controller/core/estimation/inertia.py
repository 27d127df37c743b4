"""The inertia each joint has beyond its arm model (a geared motor's rotor: armature), estimated from what the
disturbance observer sees (:class:`InertiaEstimate`). A joint heavier than its model by δ shows as ``d = −δ·a``; along
a sine ``a`` is proportional to the position, so a wrong gravity torque looks like an inertia, and only the faster
part of the motion tells them apart: the fit is a least-squares one of the observer's torque on the acceleration
(and friction's sign) with their slow parts taken away."""

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
#: the most added to a joint, as a multiple of its own inertia (the nominal model's at the design pose): a geared
#: wrist's rotor can be many times its link's (the Panda's: 0.1 kg·m² is 15 times its 0.0067), a shoulder's cannot be
#: 20 times its 1.55 kg·m²; without a bound an estimate that nothing explains (readings late beyond their stamps, an
#: oscillation) climbs for as long as the arm moves
MAX_EXTRA_RATIO = 20.0
#: a fit within this share of the joint's own inertia moves nothing: readings late by more than their stamps say look
#: heavier too (20 ms unstamped on the reference arm: 20 %), and gains raised for them would take the delay margin
DEAD_ZONE = 0.5
#: the least share of the observer's fast torque the fit (inertia and friction) must explain for it to move the
#: estimate: what it leaves is something else (a push's recovery on a coupled joint, a delay's oscillation)
MIN_EXPLAINED = 0.25
#: s, the time constant an estimate nothing supports decays with towards 0 (held still, pushed, unexplained):
#: long beside ADAPT_S, so a true rotor, confirmed whenever the joint moves, is kept through a pause
FORGET_S = 30.0


def fit(sums: tuple[float, ...]) -> tuple[float, float]:
    """One joint's least-squares fit ``d = −δ·a − f·s`` from its averaged sums (a², a·s, s², a·d, s·d, d² of the fast
    parts): δ, kg·m² beyond the model, and the share of the torque's energy the fit explains, within [0, 1]."""
    aa, a_s, ss, ad, sd, dd = sums
    aa, ss = aa + 1e-6, ss + 1e-6  # (a little ridge keeps a still joint's 2 × 2 normal equations solvable)
    det = aa * ss - a_s * a_s
    beyond = -(ss * ad - a_s * sd) / det
    friction = -(aa * sd - a_s * ad) / det
    explained = (-beyond * ad - friction * sd) / max(dd, 1e-12)  # (−δ·ad − f·sd) / dd
    return beyond, min(max(explained, 0.0), 1.0)


class InertiaEstimate:
    """Per joint, the inertia (kg·m²) the arm has beyond its model, between 0 and ``max_ratio`` × ``own_inertia``
    (never below the URDF's links). It moves only on evidence: the joint excited, its readings disagreeing with the
    filter, the fit explaining at least MIN_EXPLAINED; it is kept while the joint moves and its readings agree,
    and decays over FORGET_S otherwise. A ``blocked`` reading restarts the evidence (nothing moves for SETTLE_S).

    Its signals and sums are Python's floats, joint by joint: a few values each, where a NumPy call costs more than
    its arithmetic (tanh and exp are NumPy's, on every joint at once)."""

    def __init__(self, own_inertia: np.ndarray, max_ratio: float = MAX_EXTRA_RATIO) -> None:
        own = np.asarray(own_inertia, dtype=float)
        self._dead_zone = (DEAD_ZONE * own).tolist()
        self.bound = max_ratio * own  #: kg·m² per joint, the most the estimate holds
        self._bound = self.bound.tolist()
        self._joint_count = joint_count = len(own)
        self.extra = np.zeros(joint_count)  #: kg·m² per joint, the estimate
        self.explained = np.zeros(joint_count)  #: per joint, the share of the observer's fast torque the fit explains
        self._time_s: float | None = None  #: the last reading's (forgetting runs on it through blocked readings)
        self._last: tuple[float, list[float]] | None = None  #: (time s, velocity per joint) of the last reading
        #: per joint, the slow parts of acceleration, friction's sign and torque
        self._slow: list[tuple[float, float, float]] | None = None
        self._since_s = 0.0  #: when the signals started
        self._sums = self._no_sums()  #: per joint, averaged a², a·s, s², a·d, s·d, d² (the fast parts)

    def _no_sums(self) -> list[tuple[float, ...]]:
        return [(0.0,) * 6] * self._joint_count

    def restart(self) -> None:
        """Forget the evidence (the estimate stays, and decays unless new evidence supports it)."""
        self._last = self._slow = None
        self._sums = self._no_sums()

    def update(
        self,
        time_s: float,
        velocity: np.ndarray,
        torque: np.ndarray,
        disagreeing: np.ndarray,
        blocked: bool = False,
        paused: bool = False,
    ) -> np.ndarray:
        """Take the filter's velocity and the observer's torque per joint after a reading at ``time_s``; ``paused``:
        nothing moves on this reading (a command at the torque limit), the evidence goes on. Returns ``extra``."""
        previous_s, self._time_s = self._time_s, time_s
        elapsed = 0.0 if previous_s is None else min(max(time_s - previous_s, 0.0), MAX_GAP_S)
        velocity = np.asarray(velocity, dtype=float)
        last, self._last = self._last, (time_s, velocity.tolist())
        nothing = [False] * self._joint_count
        if blocked or last is None or not 0.0 < time_s - last[0] < MAX_GAP_S:
            if blocked:
                self.restart()
            else:
                self._slow = None
                self._sums = self._no_sums()
            return self._forget(elapsed, nothing)
        dt = time_s - last[0]
        signals = list(  # per joint: acceleration, friction's sign, torque
            zip(
                [(v - before) / dt for v, before in zip(self._last[1], last[1], strict=True)],
                np.tanh(velocity / FRICTION_SPEED).tolist(),
                np.asarray(torque, dtype=float).tolist(),
                strict=True,
            )
        )
        if self._slow is None:
            self._slow, self._since_s = signals, time_s
        follow, w = min(1.0, dt / HIGHPASS_S), min(1.0, dt / WINDOW_S)
        slow, sums = [], []
        for (a, s, d), (slow_a, slow_s, slow_d), (aa, a_s, ss, ad, sd, dd) in zip(
            signals, self._slow, self._sums, strict=True
        ):
            slow_a += follow * (a - slow_a)
            slow_s += follow * (s - slow_s)
            slow_d += follow * (d - slow_d)
            slow.append((slow_a, slow_s, slow_d))
            a, s, d = a - slow_a, s - slow_s, d - slow_d  # the fast parts
            aa, a_s, ss = aa + w * (a * a - aa), a_s + w * (a * s - a_s), ss + w * (s * s - ss)
            ad, sd, dd = ad + w * (a * d - ad), sd + w * (s * d - sd), dd + w * (d * d - dd)
            sums.append((aa, a_s, ss, ad, sd, dd))
        self._slow, self._sums = slow, sums
        fits = [fit(joint_sums) for joint_sums in sums]  # (δ, the share explained) per joint
        self.explained = np.array([share for _, share in fits])
        if paused or time_s - self._since_s < SETTLE_S:
            return self._forget(dt, nothing)
        rate, extra, supported = dt / ADAPT_S, self.extra.tolist(), []
        joints = zip(fits, sums, np.asarray(disagreeing, dtype=bool).tolist(), self._dead_zone, strict=True)
        for j, ((beyond, share), joint_sums, against, dead_zone) in enumerate(joints):
            excited = joint_sums[0] > MIN_EXCITATION
            # Up only while the readings disagree (an arm as heavy as its model is never touched); back down towards
            # the model's own whenever the fit says the estimate is too much (it overshoots by its lag while it learns).
            wanted = (against or beyond < 0.0) and abs(beyond) > dead_zone
            moving = excited and wanted and share >= MIN_EXPLAINED
            if moving:
                extra[j] += rate * beyond
            supported.append(moving or (excited and not against))  # a joint that moves as its model says
        return self._forget(dt, supported, extra)

    def _forget(self, dt: float, supported: list[bool], extra: list[float] | None = None) -> np.ndarray:
        """Decay what nothing supports over FORGET_S (``extra``: the estimate moved, else :attr:`extra`); keep the
        estimate within [0, bound]. A new array each reading (a caller compares it with the last)."""
        decay = float(np.exp(-dt / FORGET_S))
        extra = self.extra.tolist() if extra is None else extra
        kept = [
            min(max(value if keep else value * decay, 0.0), bound)
            for value, keep, bound in zip(extra, supported, self._bound, strict=True)
        ]
        self.extra = np.array(kept)
        return self.extra
