"""A payload the URDF lacks is found from a motion's torques."""

import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.core.model import ArmDynamics, MujocoPlant, Payload, fit_payload
from robot_controller.robots import ROBOTS, urdf_of


def wobble(robot: str, truth: Payload | None, torque_noise_nm: list[float]):
    """4 s of gravity compensation plus a random wobble about the home pose, 10 ms a sample."""
    urdf = urdf_of(robot)
    plant = MujocoPlant(urdf, payload=truth)
    home = np.array(ROBOTS[robot].home_position)
    n = len(home)
    plant.reset(home)
    rng = np.random.default_rng(0)
    times, positions, velocities, torques = [0.0], [home], [np.zeros(n)], [np.zeros(n)]
    hold = ArmDynamics(urdf, truth)
    for k in range(1, 400):
        q, v = plant.state()
        torque = hold.gravity(q) - 2.0 * (q - home) - 0.5 * v + rng.normal(0, torque_noise_nm)
        plant.step(torque, 10)
        q, v = plant.state()
        times.append(0.01 * k)
        positions.append(q)
        velocities.append(v)
        torques.append(torque)
    return urdf, np.array(times), np.array(positions), np.array(velocities), np.array(torques)


def test_the_fit_finds_the_mass_and_centre_of_a_payload():
    truth = Payload(1.2, (0.03, -0.02, 0.12))
    fit = fit_payload(*wobble("panda", truth, [3, 3, 3, 3, 0.5, 0.5, 0.2]))
    assert fit.payload.mass_kg == pytest.approx(1.2, rel=0.02)
    np.testing.assert_allclose(fit.payload.com_m, truth.com_m, atol=0.01)
    assert fit.residual_rms_nm < 0.2 * fit.residual_rms_without_nm
    assert fit.unidentifiable == () and np.all(np.isfinite(fit.stderr)) and fit.found


def test_on_a_planar_arm_the_offset_along_its_axes_is_named_not_identifiable():
    # Both planar2 joints turn about the link's y axis: no torque depends on the payload's y.
    truth = Payload(0.8, (0.05, 0.03, 0.1))
    fit = fit_payload(*wobble("planar2", truth, [2, 1]))
    assert fit.unidentifiable == ("y_m",)
    assert fit.payload.mass_kg == pytest.approx(0.8, rel=0.02)
    np.testing.assert_allclose(np.array(fit.payload.com_m)[[0, 2]], [0.05, 0.1], atol=0.01)
    assert fit.payload.com_m[1] == 0.0 and np.isnan(fit.stderr[2])
    assert np.all(np.isfinite(np.delete(fit.stderr, 2)))


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ([1.0, 0.0], "four finite numbers"),
        ([-1.0, 0.0, 0.0, 0.1], "mass -1 kg is not within"),
        ([1.0, 0.0, 0.0, 5.0], "over 2 m from the link"),
    ],
)
def test_a_bad_payload_is_refused_with_its_reason(values, message):
    with pytest.raises(ConfigError, match=message):
        Payload.from_values("payload", values)


def test_an_arm_carrying_nothing_is_found_to_carry_nothing():
    fit = fit_payload(*wobble("planar2", None, [2, 1]))
    assert not fit.found and fit.payload.mass_kg < 0.01
