"""Stability margins of the discrete control loop: gain, phase and delay.

The loop is the one :mod:`.lqr` designs on: each joint ``J ë + b ė = u``, zero-order hold over
``x = [∫e dt, e, ė]``, feedback ``u = −K x``, ``K = [Ki, Kp, Kd]`` (a PID and an LQR alike). Broken at the
plant input, ``L(z) = K (z I − A)⁻¹ B``, read on the unit circle ``z = e^{jθ}``, ``θ = ω·dt``: the gain margin
up (and, beyond −1, down: loops with an integrator can have a lower one), the phase margin at ``|L| = 1``, the
delay margin (phase margin over the crossover, s; in whole periods :func:`delay_margin_periods` counts them on
the delayed loop itself). They say something only of a loop stable to begin with: the spectral radius first.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields

import numpy as np

#: Frequencies the unit circle is sampled at, log-spaced from θ = 1e-5 rad (the loop has poles at z = 1) to π.
GRID_POINTS = 2048


@dataclass(frozen=True)
class Margins:
    """The margins of one loop: ``inf`` for one it does not have (its frequency NaN), all NaN if it is unstable."""

    stable: bool  #: closed-loop spectral radius below 1
    spectral_radius: float
    gain_margin_db: float  #: how much the loop gain may GROW, dB
    gain_margin_low_db: float  #: how much it may SHRINK, dB (inf: any reduction is stable)
    phase_margin_deg: float  #: the smallest over the gain crossovers
    delay_margin_s: float  #: the smallest phase margin / crossover frequency over the crossovers
    crossover_rad_s: float  #: the gain crossover of the smallest phase margin, rad/s
    phase_crossover_rad_s: float  #: where the upper gain margin is read, rad/s

    @property
    def gain_margin_both_db(self) -> float:
        """The smaller of the two gain margins (up and down), dB."""
        return float(min(self.gain_margin_db, self.gain_margin_low_db))

    def delay_margin_periods(self, dt: float) -> float:
        """The delay margin in control periods (a real number, not whole periods)."""
        return self.delay_margin_s / dt

    def as_dict(self, prefix: str = "") -> dict[str, float]:
        return {f"{prefix}{k}": int(v) if k == "stable" else v for k, v in asdict(self).items()}


def frequency_grid(points: int = GRID_POINTS) -> np.ndarray:
    """θ = ω·dt from 1e-5 rad to π (included), log-spaced."""
    return np.geomspace(1e-5, np.pi, points)


def loop_response(A: np.ndarray, B: np.ndarray, K: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``L(e^{jθ}) = K (e^{jθ} I − A)⁻¹ B`` for each θ and each gain row of ``K``: ``(m, len(theta))``."""
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float).reshape(-1, 1)
    K = np.atleast_2d(np.asarray(K, dtype=float))
    n = A.shape[0]
    z = np.exp(1j * np.asarray(theta, dtype=float))
    # (z I − A)⁻¹ B for every z at once: shape (len(theta), n)
    resolvent = np.linalg.solve(z[:, None, None] * np.eye(n) - A, np.broadcast_to(B, (len(z), n, 1)))[:, :, 0]
    return K @ resolvent.T


def spectral_radius(A: np.ndarray, B: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The closed loop's spectral radius ``max |eig(A − B K)|`` per gain row of ``K``."""
    K = np.atleast_2d(np.asarray(K, dtype=float))
    closed = np.asarray(A, dtype=float)[None] - np.asarray(B, dtype=float).reshape(1, -1, 1) * K[:, None, :]
    return np.max(np.abs(np.linalg.eigvals(closed)), axis=1)


def stable_with_delay(A: np.ndarray, B: np.ndarray, K: np.ndarray, delay: int) -> np.ndarray:
    """Whether ``x[k+1] = A x[k] − B K x[k−delay]`` is stable, per gain row of ``K``."""
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float).reshape(-1, 1)
    K = np.atleast_2d(np.asarray(K, dtype=float))
    n, size = A.shape[0], A.shape[0] * (delay + 1)
    M = np.zeros((len(K), size, size))
    M[:, :n, :n] = A
    M[:, :n, n * delay :] -= B[None] * K[:, None, :]
    M[:, n:, :-n] = np.eye(n * delay)
    return np.max(np.abs(np.linalg.eigvals(M)), axis=1) < 1.0


def delay_margin_periods(A: np.ndarray, B: np.ndarray, K: np.ndarray, max_periods: int = 50) -> np.ndarray:
    """Whole control periods of delay the loop ``u = −K x`` on ``x[k+1] = A x[k] + B u[k]`` survives, per gain
    row of ``K``: the largest ``d`` for which every delay up to it is stable (``max_periods``: at least that)."""
    K = np.atleast_2d(np.asarray(K, dtype=float))
    margin = np.full(len(K), max_periods)
    alive = np.arange(len(K))
    for delay in range(1, max_periods + 1):
        stable = stable_with_delay(A, B, K[alive], delay)
        margin[alive[~stable]] = delay - 1
        alive = alive[stable]
        if not alive.size:
            break
    return margin


def observer_delay_margin_periods(
    gains: tuple[float, float, float],
    filter_gains: tuple[np.ndarray, np.ndarray, np.ndarray],
    period_s: float,
    max_periods: int = 50,
) -> int:
    """Whole periods of delay one joint's loop survives with a Kalman filter and its disturbance observer in it
    (at rest; readings ``d`` periods old taken for the present): each tick the filter (``filter_gains``: its
    steady-state ``(F, Bf, L)`` on ``[q, q̇, d]``) predicts with the last command and corrects; the PID (``gains``
    Ki, Kp, Kd; D on the velocity error) and ``−d̂`` make the command. 0: not one period, or not stable at all."""
    ki, kp, kd = gains
    F, Bf, L = filter_gains
    Ap, Bp = F[:2, :2], Bf[:2]
    H = np.eye(2, 3)
    for delay in range(0, max_periods + 1):
        # State: the arm now and `delay` periods back (2 each), the filter's last estimate (3),
        # the I term and the last command.
        n = 2 * (delay + 1) + 5
        est, i_term, last = slice(n - 5, n - 2), n - 2, n - 1
        predicted = np.zeros((3, n))
        predicted[:, est] = F
        predicted[:, last] += Bf[:, 0]
        reading = np.zeros((2, n))
        reading[:, 2 * delay : 2 * delay + 2] = np.eye(2)
        estimate = predicted + L @ (reading - H @ predicted)
        integral = -ki * period_s * estimate[0]
        integral[i_term] += 1.0
        command = -kp * estimate[0] - kd * estimate[1] + integral - estimate[2]
        M = np.zeros((n, n))
        M[:2] = np.hstack([Ap, np.zeros((2, n - 2))]) + Bp @ command[None, :]
        M[2 : 2 * (delay + 1), : 2 * delay] = np.eye(2 * delay)  # the arm's history moves back one period
        M[est], M[i_term], M[last] = estimate, integral, command
        if np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
            return max(delay - 1, 0)
    return max_periods


def _sign_changes(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and interpolation fraction of every sign change between consecutive columns."""
    a, b = values[:, :-1], values[:, 1:]
    rows, cols = np.nonzero(((a < 0) & (b >= 0)) | ((a > 0) & (b <= 0)))
    va, vb = a[rows, cols], b[rows, cols]
    fraction = va / (va - vb)
    return rows, cols, fraction


def margins_batch(
    A: np.ndarray, B: np.ndarray, K: np.ndarray, dt: float, theta: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """The :class:`Margins` of many gain rows of ``K`` at once, for searches: one array per field, one entry per
    row (crossings interpolated linearly between grid points)."""
    K = np.atleast_2d(np.asarray(K, dtype=float))
    theta = frequency_grid() if theta is None else np.asarray(theta, dtype=float)
    m = len(K)
    radius = spectral_radius(A, B, K)
    stable = radius < 1.0
    L = loop_response(A, B, K, theta)
    inf = np.full(m, np.inf)
    gain_up, gain_low, phase_x = inf.copy(), inf.copy(), np.full(m, np.nan)

    def negative_crossing(row: int, a: float, w: float) -> None:
        if a < 1.0:
            margin = -20.0 * np.log10(a) if a > 0 else np.inf
            if margin < gain_up[row]:
                gain_up[row], phase_x[row] = margin, w
        else:
            gain_low[row] = min(gain_low[row], 20.0 * np.log10(a))

    # Crossings of the real axis (Im L = 0) on its negative side.
    rows, cols, frac = _sign_changes(L.imag)
    re = L.real[rows, cols] + frac * (L.real[rows, cols + 1] - L.real[rows, cols])
    w = (theta[cols] + frac * (theta[cols + 1] - theta[cols])) / dt
    for row, value, omega in zip(rows, re, w, strict=True):
        if value < 0:
            negative_crossing(int(row), float(-value), float(omega))
    # At θ = π, L is real: a point of the negative real axis if L(−1) < 0.
    if np.isclose(theta[-1], np.pi):
        for row in np.flatnonzero(L[:, -1].real < 0):
            negative_crossing(int(row), float(-L[row, -1].real), float(np.pi / dt))
    # Gain crossovers (|L| = 1) and the phase there.
    rows, cols, frac = _sign_changes(np.log(np.abs(L)))
    at = L[rows, cols] + frac * (L[rows, cols + 1] - L[rows, cols])
    w = (theta[cols] + frac * (theta[cols + 1] - theta[cols])) / dt
    pm = _wrap_deg(180.0 + np.degrees(np.angle(at)))
    phase_margin, crossover, delay = inf.copy(), np.full(m, np.nan), inf.copy()
    for row, margin, omega in zip(rows, pm, w, strict=True):
        if margin < phase_margin[row]:
            phase_margin[row], crossover[row] = margin, omega
        delay[row] = min(delay[row], np.radians(margin) / omega if margin > 0 else 0.0)
    out = {"stable": stable, "spectral_radius": radius}
    found = (gain_up, gain_low, phase_margin, delay, crossover, phase_x)
    for field, value in zip(fields(Margins)[2:], found, strict=True):
        out[field.name] = np.where(stable, value, np.nan)
    return out


def _wrap_deg(angle: np.ndarray) -> np.ndarray:
    """Into (−180°, 180°]."""
    return 180.0 - np.mod(180.0 - np.asarray(angle, dtype=float), 360.0)


def margins(A: np.ndarray, B: np.ndarray, K: np.ndarray, dt: float, points: int = 16384) -> Margins:
    """The margins of one loop at the control period ``dt`` (s), on a fine grid of the unit circle."""
    values = margins_batch(A, B, np.atleast_2d(K)[:1], dt, frequency_grid(points))
    return Margins(bool(values["stable"][0]), *(float(values[f.name][0]) for f in fields(Margins)[1:]))


def pid_gain_row(kp: float, ki: float, kd: float) -> np.ndarray:
    """The feedback row on ``[∫e, e, ė]`` of a PID (and of an LQR's designed gains)."""
    return np.array([[ki, kp, kd]], dtype=float)


def poles(A: np.ndarray, B: np.ndarray, K: np.ndarray) -> np.ndarray:
    """The closed loop's poles (eigenvalues of ``A − B K``), sorted by magnitude, largest first."""
    closed = np.asarray(A, dtype=float) - np.asarray(B, dtype=float).reshape(-1, 1) @ np.atleast_2d(K)
    values = np.linalg.eigvals(closed)
    return values[np.argsort(-np.abs(values), kind="stable")]


def pole_summary(z: complex, dt: float) -> tuple[float, float]:
    """A discrete pole's natural frequency (rad/s) and damping ratio as the continuous one it samples
    (``s = ln z / dt``); NaN, NaN on the negative real axis (no continuous equivalent)."""
    if abs(z) == 0 or (abs(z.imag) < 1e-12 and z.real < 0):
        return float("nan"), float("nan")
    s = np.log(complex(z)) / dt
    wn = abs(s)
    return float(wn), float(-s.real / wn) if wn > 0 else float("nan")
