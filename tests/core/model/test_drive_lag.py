"""A drive's first-order lag inverted and identified against the drive's own model (``Actuator``): the inversion
makes it apply what the law wants from its first command on and after a stop, within its torque limit; a lag
inverted up to twice the drive's still settles; ``fit_lag`` finds the lag from the commands and the torques."""

import numpy as np
import pytest

from robot_controller.core.model.actuator import Actuator
from robot_controller.core.model.drive_lag import LagInversion, fit_lag, lag_share

PERIOD_S = 0.01
LIMIT_NM = np.array([40.0, 3.0])


def drive_it(inversion: LagInversion, drive: Actuator, wanted: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each row of ``wanted`` through the inversion and the drive (its first command after ``dt`` 0, as the drive
    node gives it); the commands and the torques applied."""
    commands, applied = [], []
    for k, row in enumerate(wanted):
        command = inversion.command(row, PERIOD_S)
        commands.append(command)
        applied.append(drive.apply(command, 0.0 if k == 0 else PERIOD_S))
    return np.array(commands), np.array(applied)


def wanted_torques(ticks: int = 300) -> np.ndarray:
    t = np.arange(ticks) * PERIOD_S
    return np.column_stack([5.0 * np.sin(2 * np.pi * 0.5 * t), 0.4 * np.sign(np.sin(2 * np.pi * t))])


def test_the_drive_applies_what_the_law_wants():
    wanted = wanted_torques()
    inversion, drive = LagInversion(0.02, LIMIT_NM), Actuator(LIMIT_NM, 0.02)
    commands, applied = drive_it(inversion, drive, wanted)
    np.testing.assert_allclose(applied[1:], wanted[1:], atol=1e-12)  # (the first command moves nothing)
    assert np.all(applied[0] == 0.0)
    np.testing.assert_allclose(inversion.applied, drive.applied, atol=1e-12)
    # uninverted, the drive is 20 ms late: 0.4 N·m steps reach a third of their way in a period
    plain = np.array([Actuator(LIMIT_NM, 0.02).apply(row, PERIOD_S) for row in wanted])
    assert np.abs(plain - wanted)[1:].max() > 0.3
    # after a stop (the drive's torque gone, its lag from zero again) as from the start
    inversion.reset()
    drive = Actuator(LIMIT_NM, 0.02)
    _, again = drive_it(inversion, drive, wanted[:50])
    np.testing.assert_allclose(again[1:], wanted[1:50], atol=1e-12)


def test_within_the_torque_limit_and_as_far_as_it_takes_the_torque():
    inversion, drive = LagInversion(0.02, LIMIT_NM), Actuator(LIMIT_NM, 0.02)
    wanted = np.tile([0.0, 2.9], (20, 1))  # a step the inversion would ask 8.7 N·m for, of 3
    commands, applied = drive_it(inversion, drive, wanted)
    assert np.all(np.abs(commands) <= LIMIT_NM)
    np.testing.assert_allclose(inversion.applied, drive.applied, atol=1e-12)
    assert applied[-1, 1] == pytest.approx(2.9, abs=1e-6)


@pytest.mark.parametrize("believed_s", [0.01, 0.038])
def test_a_lag_inverted_wrongly_within_twice_the_drives_still_settles(believed_s):
    inversion, drive = LagInversion(believed_s, LIMIT_NM), Actuator(LIMIT_NM, 0.02)
    wanted = np.tile([0.0, 0.4], (200, 1))
    _, applied = drive_it(inversion, drive, wanted)
    assert abs(applied[-1, 1] - 0.4) < 1e-3
    assert lag_share(believed_s, PERIOD_S) < 2 * lag_share(0.02, PERIOD_S)


def test_the_lag_is_found_from_the_commands_and_the_torques():
    rng = np.random.default_rng(3)
    drive = Actuator(LIMIT_NM, 0.0153)
    commands = np.column_stack([10 * np.sin(np.arange(500) * 0.05), rng.uniform(-2, 2, 500)])
    applied = np.array([drive.apply(c, PERIOD_S) for c in commands])
    lag_s, stderr_s = fit_lag(commands, applied, PERIOD_S)
    assert lag_s == pytest.approx(0.0153, rel=1e-9) and stderr_s < 1e-9
    assert fit_lag(commands, commands, PERIOD_S) == (0.0, 0.0)  # a drive without lag
    assert fit_lag(np.zeros((10, 2)), np.zeros((10, 2)), PERIOD_S) == (0.0, 0.0)  # nothing commanded
