"""Gain, phase and delay margins of the sampled loop (core.robustness), against textbook cases."""

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

from robot_controller.core.laws import lqr, robustness

INERTIA, DAMPING, DT = 1.0 / 12.0, 0.1, 0.01


def zoh(Ac: np.ndarray, Bc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    n = Ac.shape[0]
    block = np.zeros((n + 1, n + 1))
    block[:n, :n], block[:n, n:] = Ac, Bc
    phi = expm(block * dt)
    return phi[:n, :n], phi[:n, n:]


@pytest.mark.parametrize("c", [0.2, 0.5, 1.0, 1.5])
def test_a_sampled_integrator_has_its_closed_form_margins(c):
    # L(z) = c / (z − 1): at z = −1, L = −c/2, so GM = 2/c; |L| = 1 where 2 sin(θ/2) = c, the phase
    # there is −90° − θ/2, so PM = 90° − θ/2.
    m = robustness.margins(np.array([[1.0]]), np.array([[1.0]]), np.array([[c]]), DT)
    theta = 2 * np.arcsin(c / 2)
    assert m.stable
    assert m.gain_margin_db == pytest.approx(20 * np.log10(2 / c), abs=1e-6)
    assert m.gain_margin_low_db == np.inf
    assert m.phase_margin_deg == pytest.approx(90 - np.degrees(theta) / 2, abs=1e-3)
    assert m.crossover_rad_s == pytest.approx(theta / DT, rel=1e-4)
    assert m.phase_crossover_rad_s == pytest.approx(np.pi / DT)
    assert m.delay_margin_s == pytest.approx(np.radians(m.phase_margin_deg) / m.crossover_rad_s)


def test_the_textbook_third_order_loop_sampled_fast_has_its_continuous_margins():
    # L(s) = 10 / (s (s + 1) (s + 5)): phase −180° at ω = √5, where |L| = 10/30, so GM = 3 (9.54 dB);
    # PM from |L(jω)| = 1 (about 25.4°). Sampled every 1 ms, the hold's lag changes them by < 0.05.
    Ac = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, -5.0, -6.0]])
    Bc = np.array([[0.0], [0.0], [1.0]])
    dt = 1e-3
    A, B = zoh(Ac, Bc, dt)
    m = robustness.margins(A, B, np.array([[10.0, 0.0, 0.0]]), dt)
    w_c = brentq(lambda w: w * np.sqrt(w * w + 1) * np.sqrt(w * w + 25) - 10.0, 0.1, 5.0)
    pm = 90.0 - np.degrees(np.arctan(w_c)) - np.degrees(np.arctan(w_c / 5))
    assert m.gain_margin_db == pytest.approx(20 * np.log10(3.0), abs=0.05)
    assert m.phase_crossover_rad_s == pytest.approx(np.sqrt(5.0), rel=2e-3)
    assert m.phase_margin_deg == pytest.approx(pm, abs=0.1)
    assert m.crossover_rad_s == pytest.approx(w_c, rel=2e-3)


@pytest.mark.parametrize("gains", [(50.0, 10.0, 5.0), (29.7, 27.5, 2.15), (200.0, 50.0, 8.0), (10.0, 0.5, 1.0)])
def test_the_gain_margin_is_where_scaling_the_gains_destabilises_the_arm(gains):
    A, B = lqr.discretise(INERTIA, DAMPING, DT)
    K = robustness.pid_gain_row(*gains)
    m = robustness.margins(A, B, K, DT)
    assert m.stable
    factor = 10 ** (m.gain_margin_db / 20)
    assert robustness.spectral_radius(A, B, K * factor * 0.995)[0] < 1.0
    assert robustness.spectral_radius(A, B, K * factor * 1.005)[0] > 1.0


def test_a_conditionally_stable_loop_has_a_lower_gain_margin():
    # Much integral, little proportional: stable as given, unstable once the gain drops (Kp/Ki < J/b).
    A, B = lqr.discretise(INERTIA, DAMPING, DT)
    K = robustness.pid_gain_row(60.0, 1400.0, 4.0)
    m = robustness.margins(A, B, K, DT)
    assert m.stable and np.isfinite(m.gain_margin_low_db)
    low = 10 ** (-m.gain_margin_low_db / 20)
    assert robustness.spectral_radius(A, B, K * low * 1.005)[0] < 1.0
    assert robustness.spectral_radius(A, B, K * low * 0.995)[0] > 1.0
    assert m.gain_margin_both_db == pytest.approx(min(m.gain_margin_db, m.gain_margin_low_db))


@pytest.mark.parametrize("q, r", [((1e4, 1e4, 1.0), 10.0), ((1e4, 1e4, 1.0), 1e-2), ((1.0, 100.0, 1.0), 1.0)])
def test_the_delay_margin_agrees_with_the_whole_periods_the_loop_survives(q, r):
    design = lqr.design(INERTIA, DAMPING, DT, np.array(q), r)
    m = robustness.margins(design.A, design.B, design.K, DT)
    periods = robustness.delay_margin_periods(design.A, design.B, design.K)[0]
    assert int(np.floor(m.delay_margin_periods(DT))) == periods
    for delay in range(1, periods + 2):
        assert robustness.stable_with_delay(design.A, design.B, design.K, delay)[0] == (delay <= periods)


def test_many_loops_at_once_match_one_at_a_time():
    A, B = lqr.discretise(INERTIA, DAMPING, DT)
    rng = np.random.default_rng(1)
    rows = 10 ** np.column_stack([rng.uniform(-1, 2.5, 40), rng.uniform(0, 3, 40), rng.uniform(-1, 1.3, 40)])
    batch = robustness.margins_batch(A, B, rows, DT)
    for i in range(0, 40, 7):
        one = robustness.margins(A, B, rows[i : i + 1], DT)
        assert bool(batch["stable"][i]) == one.stable
        if one.stable:
            assert batch["gain_margin_db"][i] == pytest.approx(one.gain_margin_db, abs=0.05)
            assert batch["phase_margin_deg"][i] == pytest.approx(one.phase_margin_deg, abs=0.3)
        else:
            assert np.isnan(batch["phase_margin_deg"][i])


def test_an_unstable_loop_has_no_margins():
    A, B = lqr.discretise(INERTIA, DAMPING, DT)
    m = robustness.margins(A, B, robustness.pid_gain_row(50.0, 0.0, 0.0), DT)  # P alone: beyond Ku ≈ 20
    assert not m.stable and m.spectral_radius > 1.0
    assert np.isnan(m.gain_margin_db) and np.isnan(m.phase_margin_deg)


def test_poles_and_their_continuous_equivalent():
    A, B = lqr.discretise(INERTIA, DAMPING, DT)
    poles = robustness.poles(A, B, robustness.pid_gain_row(50.0, 10.0, 5.0))
    assert np.all(np.diff(np.abs(poles)) <= 0)
    wn, zeta = robustness.pole_summary(complex(np.exp(-0.5 * DT)), DT)
    assert wn == pytest.approx(0.5) and zeta == pytest.approx(1.0)
    wn, zeta = robustness.pole_summary(np.exp(complex(-3.0, 4.0) * DT), DT)
    assert wn == pytest.approx(5.0) and zeta == pytest.approx(0.6)
