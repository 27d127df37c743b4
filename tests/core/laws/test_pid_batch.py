"""One joint's PID gives what the same joint as a batch of one gives, to rounding, in every mode."""

import numpy as np
import pytest

from robot_controller.core.laws.pid import AntiWindup, DerivativeSource, Pid
from tests.core import configs


@pytest.mark.parametrize("anti_windup", list(AntiWindup))
@pytest.mark.parametrize("source", list(DerivativeSource))
@pytest.mark.parametrize("options", [{}, {"derivative_filter_time_s": 0.02, "slew_rate_limit": 200.0}])
def test_one_joint_is_a_batch_of_one(anti_windup, source, options):
    config = configs.pid(
        kp=[40.0],
        ki=[15.0],
        kd=[3.0],
        output_limit=[4.0],
        integral_limit=[0.05],
        anti_windup=anti_windup,
        derivative_source=source,
        **options,
    )
    one, batch = Pid(config), Pid(config)  # batch: the same joint as a batch of one, (1, 1), on arrays
    rng = np.random.default_rng(3)
    for k in range(300):
        r, rv, y, yv = rng.normal(0.0, [0.3, 2.0, 0.3, 2.0])
        ff = float(rng.normal(0.0, 2.0)) if k % 2 else np.array([rng.normal(0.0, 2.0)])
        if k == 100:
            r = np.nan  # a non-finite input: zero command, state untouched
        a = one.step(0.01, np.array([r]), np.array([rv]), np.array([y]), np.array([yv]), ff)
        b = batch.step(0.01, np.array([[r]]), np.array([[rv]]), np.array([[y]]), np.array([[yv]]), ff)
        for name in ("command", "p", "i", "d", "feedforward", "saturated"):
            np.testing.assert_allclose(getattr(a, name), getattr(b, name).reshape(1), rtol=1e-12, atol=1e-15)
        assert a.command.shape == (1,)
