"""The in-process loop built ahead (what the bench times) runs as the one-call simulation does."""

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments import inprocess


def test_a_prepared_loop_is_the_simulation():
    params = cfg.load_stack()
    run = inprocess.prepare(params, duration_s=1.0, seed=2)
    prepared, simulated = run(), inprocess.simulate(params, duration_s=1.0, seed=2)
    for name in ("reference", "measured", "true_position", "command", "applied"):
        np.testing.assert_array_equal(getattr(prepared, name), getattr(simulated, name))
