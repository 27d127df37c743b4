"""Coulomb (dry) friction as the controller's feedforward carries it: ``f_c·tanh(v / COULOMB_SMOOTH_RAD_S)``, the
torque a moving joint's friction takes, smoothed through zero speed so a reversal of the reference turns it over in a
few milliseconds instead of one tick's jump (which would chatter on a noisy velocity, and kick a light joint).

MuJoCo's own ``frictionloss`` is a soft constraint: its inverse dynamics grows linearly up to a speed set by the
joint's inertia (1.6 rad/s on a 0.0003 kg·m² wrist), so a light joint's feedforward through it gives almost none of
its friction. The controller's model keeps MuJoCo's friction for its forward prediction (stable at any step) and
takes this one for the torque a motion needs."""

from __future__ import annotations

import mujoco
import numpy as np

#: The friction's constraint where it sticks: its time constant in physics steps, and its impedance (MuJoCo's solref,
#: solimp). MuJoCo's friction is a soft constraint: at its defaults a joint held below breakaway creeps at about 1e-3 s
#: times the acceleration the torque alone would give (0.1 rad/s on the Panda's wrist under 0.5 N·m), and on a light
#: joint it acts as a viscous damping far above its own (0.19 N·m·s/rad on a 0.0003 kg·m² wrist under 0.3 N·m). Made
#: as stiff as a brake, it creeps a hundred times slower and slips as dry friction does.
STICTION_TIME_STEPS = 2
STICTION_IMPEDANCE = 0.99

#: rad/s: 76 % of the friction at this speed, 99.5 % at three times it; a reference reverses through it in a few ms
COULOMB_SMOOTH_RAD_S = 0.01


def coulomb_torque(friction_nm: np.ndarray, velocity: np.ndarray) -> np.ndarray:
    """The torque (N·m) each joint's dry friction of ``friction_nm`` takes at ``velocity`` (rad/s)."""
    return friction_nm * np.tanh(np.asarray(velocity, dtype=float) / COULOMB_SMOOTH_RAD_S)


def make_friction_stick(model: mujoco.MjModel, dofs: np.ndarray, step_s: float) -> None:
    """Make the dry friction of ``model``'s ``dofs`` stick (``STICTION_*``) at a physics step of ``step_s``: MuJoCo
    keeps the time constant at two steps or more of whatever step it is taken at."""
    model.dof_solref[dofs] = [STICTION_TIME_STEPS * step_s, 1.0]
    model.dof_solimp[dofs, :2] = STICTION_IMPEDANCE
