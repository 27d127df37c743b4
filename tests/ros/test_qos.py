"""Every QoS class the graph spec names is a profile of ``ros.qos``, in both clock modes."""

import pytest
from rclpy.qos import DurabilityPolicy

from robot_controller.blocks import spec
from robot_controller.ros import qos


@pytest.mark.parametrize("lockstep", [False, True])
@pytest.mark.parametrize("qos_class", spec.QOS_CLASSES)
def test_every_class_is_a_profile(qos_class, lockstep):
    assert qos.profile(qos_class, lockstep=lockstep).depth >= 1


def test_the_readings_are_transient_local_in_lockstep_only():
    assert qos.profile(spec.READING.qos, lockstep=True) is qos.LOCKSTEP_READINGS_READER_QOS
    assert qos.profile(spec.READING.writer_qos, lockstep=True) is qos.LOCKSTEP_READINGS_QOS
    assert qos.profile(spec.READING.qos, lockstep=False).durability == DurabilityPolicy.VOLATILE
    assert qos.profile(spec.BRAKE_REQUEST.qos, lockstep=False) is qos.LATCHED_QOS
