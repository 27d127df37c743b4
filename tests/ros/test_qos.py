"""Every QoS class the graph spec names is a profile of ``ros.qos``, in both clock modes."""

import pytest
from rclpy.qos import DurabilityPolicy

from robot_controller.blocks import spec
from robot_controller.ros import qos


@pytest.mark.parametrize("world_waits", [False, True])
@pytest.mark.parametrize("qos_class", spec.QOS_CLASSES)
def test_every_class_is_a_profile(qos_class, world_waits):
    assert qos.profile(qos_class, world_waits=world_waits).depth >= 1


def test_the_readings_are_transient_local_where_the_world_waits_only():
    assert qos.profile(spec.READING.qos, world_waits=True) is qos.SIM_TIME_READINGS_READER_QOS
    assert qos.profile(spec.READING.writer_qos, world_waits=True) is qos.SIM_TIME_READINGS_QOS
    assert qos.profile(spec.READING.qos, world_waits=False).durability == DurabilityPolicy.VOLATILE
    assert qos.profile(spec.BRAKE_REQUEST.qos, world_waits=False) is qos.LATCHED_QOS
