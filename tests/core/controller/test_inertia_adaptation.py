"""The inertia adaptation on the in-process Panda (no ROS): learnt where the arm is heavier, bounded, never
compounding with a redesign, and left alone by a push."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.experiments import inprocess
from robot_controller.experiments.inprocess import Disturbance

WRIST = {"armature_kgm2": [0.0] * 6 + [0.1]}


def panda(simulator=None, changes=(), disturbance=None, duration_s=10.0):
    """The default Panda loop; ``changes``: (time s, pid_controller values) set while it runs, as ``param set``
    does. Returns the controller, the joint 7 Kp before each change and at the end, and the loop's result."""
    params = cfg.merge(cfg.load_stack(robot="panda"), {"simulator": simulator or {}})
    loop = inprocess.prepare(params, duration_s=duration_s, seed=0, disturbance=disturbance)
    controller = loop.keywords["controller"]
    pending, kp = list(changes), []
    update = controller.update

    def update_with_changes(now_s):
        while pending and now_s >= pending[0][0]:
            values = dict(params["pid_controller"], lockstep=True, **pending.pop(0)[1])
            kp.append(controller.gains.kp[6])
            controller.set_config(cfg.controller_config(values, controller.joint_count))
        return update(now_s)

    controller.update = update_with_changes
    result = loop()
    return controller, kp + [controller.gains.kp[6]], result


def test_the_wrist_rotor_is_learnt_and_three_redesigns_leave_its_gains_where_they_were():
    changes = [(4.0, {"lqr_r": 5.0}), (6.0, {"lqr_r": 10.0}), (8.0, {"kp": [60.0]})]
    controller, kp, result = panda(WRIST, changes)
    learnt = controller.inertia.armature
    assert 0.07 < learnt[6] < 0.14 and np.all(learnt[:6] == 0.0)  # 0.130 (the bound: 20 × 0.0067 = 0.134)
    assert result.tracking_metrics()["tracking_rms_rad"] < 0.005  # 2.2 mrad
    before, lqr_r_5, back, end = kp  # 55.2, 81.0 (lqr_r 5's own design is 1.36 × the default's), 59.5, 59.4
    assert kp[0] > 4 * controller.pid.config.kp[6] / controller.inertia.scale[6]  # raised with the learnt inertia
    assert before / 1.5 < back < 1.5 * before and before / 1.5 < end < 1.5 * before  # (compounding: × 26)
    assert lqr_r_5 < 1.5 * before
    assert controller.delay_margin_periods() >= controller.config.min_delay_margin_periods
    assert "inertia adaptation: gains ×" in controller.law_in_force()


@pytest.mark.parametrize("torque_nm", [30.0, 40.0])
@pytest.mark.parametrize("held", [False, True])
def test_a_push_on_the_nominal_shoulder_leaves_every_joint_within_1_percent_of_its_own_inertia(torque_nm, held):
    push = Disturbance(np.array([torque_nm] + [0.0] * 6), 3.0, 100.0 if held else 0.3)
    controller, _, _ = panda(disturbance=push, duration_s=8.0)
    inertia = controller.inertia
    assert np.all(inertia.armature <= 0.01 * (inertia.inertia - inertia.armature))
    assert np.all(inertia.scale == 1.0)
