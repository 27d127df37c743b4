"""Which of a joint's fitted armature, damping and friction the data tells from the URDF's values.

A value the motion does not tell from the URDF's is noise the overlay would impose on the controller (on a Panda
carrying a payload, damping fitted at 9 × the URDF's and a friction of 0.0002 N·m, which switches the controller to
sticking friction, cost 1.8 mrad of tracking on the wrist). So a value stays the URDF's unless setting it there, the
others refitted, leaves a meaningfully larger residual: backward elimination, cheapest first, while the residual's
RMS stays within its ``TOLD_SHARE`` more than the full fit's."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Per parameter (armature, damping, Coulomb friction): setting it at the URDF's, the others refitted, leaves at most
#: this share more residual RMS than all three fitted: not told apart. On a simulated Panda whose joints are the
#: URDF's (with 1, 2 or 3 kg on the flange, or with friction added), what the fit's errors make up costs an armature
#: up to 9 % (panda_joint7's 1.9e-6 kg·m²: the simulator's implicit damping, b × half its step) and a damping up to
#: 100 %: the velocity column takes up what the fit gets wrong in proportion to speed (panda_joint2's damping fits
#: 0.02 N·m·s/rad against the URDF's 0.003, with a payload or without). On a 3-joint arm with values added, the
#: cheapest told costs 38 % for an armature (the wrist's 0.0001 kg·m² under a 0.5 kg payload), 440 % for a damping,
#: 230 % for a friction. Each bar sits about halfway (in ratio) between; a friction the fit makes up and the bar
#: lets through (up to 119 %) is under the floor below.
TOLD_SHARE = np.array([0.2, 2.0, 0.1])
#: Residual RMS below this, N·m, is numerical: an exact fit is not made worse by a value at the URDF's.
NUMERICAL_NM = 1e-9
#: A Coulomb friction below this share of the joint's effort limit is none (an overlay friction above 0, however
#: small, switches the controller's model to sticking friction).
FRICTION_FLOOR_SHARE = 1e-3


@dataclass(frozen=True)
class Parsimonious:
    values: np.ndarray  #: the parameters: fitted where told, the URDF's (or 0 for a friction under the floor) where not
    kept: tuple[bool, ...]  #: per parameter, set to the URDF's (or the friction to none): not told apart
    cost: tuple[float, ...]  #: per parameter, the share of residual RMS setting it there added, when decided
    residual: np.ndarray  #: what ``values`` leave


def _fit(X: np.ndarray, y: np.ndarray, fixed: dict[int, float]) -> tuple[np.ndarray, np.ndarray]:
    """Least squares with the ``fixed`` parameters at their values: ``(parameters, residual)``."""
    beta = np.zeros(X.shape[1])
    for i, value in fixed.items():
        beta[i] = value
    free = [i for i in range(X.shape[1]) if i not in fixed]
    target = y - X @ beta
    if free:
        beta[free] = np.linalg.lstsq(X[:, free], target, rcond=None)[0]
    return beta, y - X @ beta


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2)))


def parsimonious(
    X: np.ndarray, y: np.ndarray, reference: np.ndarray, *, friction_column: int, friction_floor_nm: float
) -> Parsimonious:
    """Fit ``y ≈ X β``, each parameter at its ``reference`` (the URDF's) unless the residual tells it from there."""
    full = _rms(_fit(X, y, {})[1])
    fixed: dict[int, float] = {}
    cost = np.full(X.shape[1], np.nan)

    def share(rms: float) -> float:
        if full > NUMERICAL_NM:
            return (rms - full) / full
        return np.inf if rms > NUMERICAL_NM else 0.0  # an exact fit: any torque left tells the value apart

    while len(fixed) < X.shape[1]:
        for i in range(X.shape[1]):
            if i not in fixed:
                cost[i] = share(_rms(_fit(X, y, {**fixed, i: float(reference[i])})[1]))
        # The cheapest against its own bar first: a parameter set at the URDF's changes what the others cost.
        cheapest = min((i for i in range(X.shape[1]) if i not in fixed), key=lambda i: cost[i] / TOLD_SHARE[i])
        if cost[cheapest] > TOLD_SHARE[cheapest]:
            break
        fixed[cheapest] = float(reference[cheapest])
    beta, _ = _fit(X, y, fixed)
    f = friction_column
    if f not in fixed and abs(beta[f]) < friction_floor_nm:
        fixed[f] = 0.0  # too small to be a friction: none, the others refitted without it
        cost[f] = share(_rms(_fit(X, y, fixed)[1]))
    beta, residual = _fit(X, y, fixed)
    kept = tuple(i in fixed for i in range(X.shape[1]))
    return Parsimonious(values=beta, kept=kept, cost=tuple(float(c) for c in cost), residual=residual)
