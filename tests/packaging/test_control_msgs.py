"""control_msgs as the install builds it (interfaces/control_msgs, tools/build_control_msgs.py)
speaks Jazzy's FollowJointTrajectory: its RIHS01 type hash, which rmw checks on the wire, is
that of a real control_msgs build. The action's hash covers the goal, result and feedback
and every type they name, so one field out of place anywhere changes it."""

import ctypes

import pytest

JAZZY_FOLLOW_JOINT_TRAJECTORY = "RIHS01_738ebcb7a2d7cfa42f9f1001cc99ce3a4383d1cfe508015d9be8485e4b1c66f6"


class TypeHash(ctypes.Structure):
    """rosidl_type_hash_t: a version byte and 32 bytes of sha256."""

    _fields_ = [("version", ctypes.c_uint8), ("value", ctypes.c_uint8 * 32)]


def compiled_type_hash(symbol: str) -> str:
    """The hash compiled into control_msgs' generated C library, as rcl reads it (``RIHS01_<hex>``)."""
    from control_msgs.action import FollowJointTrajectory  # loads the library into this process

    assert FollowJointTrajectory is not None
    library = ctypes.CDLL("libcontrol_msgs__rosidl_generator_c.so")
    function = getattr(library, f"control_msgs__{symbol}__get_type_hash")
    function.restype = ctypes.POINTER(TypeHash)
    function.argtypes = [ctypes.c_void_p]
    found = function(None).contents
    return f"RIHS{found.version:02d}_" + bytes(found.value).hex()


def test_follow_joint_trajectory_has_jazzys_type_hash():
    assert compiled_type_hash("action__FollowJointTrajectory") == JAZZY_FOLLOW_JOINT_TRAJECTORY


@pytest.mark.parametrize("part", ["Goal", "Result", "Feedback", "FeedbackMessage"])
def test_rclpy_sees_the_compiled_hash_of_each_part(part):
    """What rclpy puts on a topic of the action's part is the compiled hash (no stale library)."""
    import rclpy
    from control_msgs.action import FollowJointTrajectory

    message = getattr(FollowJointTrajectory, part, None) or getattr(FollowJointTrajectory.Impl, part)
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = rclpy.create_node("hash_probe", context=context, start_parameter_services=False)
        node.create_publisher(message, "hash_probe", 1)
        (info,) = node.get_publishers_info_by_topic("hash_probe")
        assert str(info.topic_type_hash) == compiled_type_hash(f"action__FollowJointTrajectory_{part}")
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
