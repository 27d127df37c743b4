"""A payload the URDF lacks is found from a motion's torques."""

import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.core.payload import Payload
from robot_controller.core.payload_identification import fit_payload
from robot_controller.core.plant import MujocoPlant
from robot_controller.robots import ROBOTS, urdf_of


def test_the_fit_finds_the_mass_and_centre_of_a_payload():
    urdf = urdf_of("panda")
    truth = Payload(1.2, (0.03, -0.02, 0.12))
    plant = MujocoPlant(urdf, payload=truth)
    home = np.array(ROBOTS["panda"].home_position)
    plant.reset(home)
    rng = np.random.default_rng(0)
    times, positions, velocities, torques = [0.0], [home], [np.zeros(7)], [np.zeros(7)]
    from robot_controller.core.plant import ArmDynamics

    hold = ArmDynamics(urdf, truth)
    for k in range(1, 400):  # 4 s of gravity compensation plus a random wobble, 10 ms a sample
        q, v = plant.state()
        torque = hold.gravity(q) - 2.0 * (q - home) - 0.5 * v + rng.normal(0, [3, 3, 3, 3, 0.5, 0.5, 0.2])
        plant.step(torque, 10)
        q, v = plant.state()
        times.append(0.01 * k)
        positions.append(q)
        velocities.append(v)
        torques.append(torque)
    fit = fit_payload(urdf, np.array(times), np.array(positions), np.array(velocities), np.array(torques))
    assert fit.payload.mass_kg == pytest.approx(1.2, rel=0.02)
    np.testing.assert_allclose(fit.payload.com_m, truth.com_m, atol=0.01)
    assert fit.residual_rms_nm < 0.2 * fit.residual_rms_without_nm


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
