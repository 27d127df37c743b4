"""The tools' formatting and parsing, without a graph: what ros2cli would print
for a message, a parameter value, a rate; how a typed value becomes a parameter."""

import subprocess
import sys

import pytest
import yaml
from rcl_interfaces.msg import ParameterValue
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, MultiArrayLayout

from robot_controller.tools import param, topic
from robot_controller.tools import param as p
from robot_controller.tools.param import BOOL, DOUBLE, DOUBLE_ARRAY, INTEGER, STRING

BOOL_ARRAY, INTEGER_ARRAY, STRING_ARRAY = p.BOOL_ARRAY, p.INTEGER_ARRAY, p.STRING_ARRAY


def joint_state() -> JointState:
    msg = JointState(name=["joint1"], position=[0.5], velocity=[-0.25])
    msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id = 5, 6, "base"
    return msg


def command() -> Float64MultiArray:
    layout = MultiArrayLayout(dim=[MultiArrayDimension(label="joints", size=1, stride=1)])
    return Float64MultiArray(layout=layout, data=[1.5])


def test_a_message_prints_as_ros2_topic_echo_yaml_nested_fields_indented_sequences_as_items():
    assert topic.message_to_yaml(joint_state()) == (
        "header:\n"
        "  stamp:\n"
        "    sec: 5\n"
        "    nanosec: 6\n"
        "  frame_id: base\n"
        "name:\n"
        "- joint1\n"
        "position:\n"
        "- 0.5\n"
        "velocity:\n"
        "- -0.25\n"
        "effort: []\n"
    )
    assert topic.message_to_yaml(command()) == (
        "layout:\n"
        "  dim:\n"
        "  - label: joints\n"
        "    size: 1\n"
        "    stride: 1\n"
        "  data_offset: 0\n"
        "data:\n"
        "- 1.5\n"
    )
    assert topic.message_to_yaml(Float64MultiArray()) == "layout:\n  dim: []\n  data_offset: 0\ndata: []\n"


def test_a_message_prints_as_one_csv_line_of_its_values_in_field_order():
    assert topic.message_to_csv(joint_state()) == "5,6,base,joint1,0.5,-0.25,"  # effort: empty, an empty cell
    assert topic.message_to_csv(command()) == "joints,1,1,0,1.5"
    assert topic.message_to_csv(Float64MultiArray(data=[1.0, 2.0])) == ",0,1.0,2.0"


def test_the_csv_header_names_each_column_of_the_line():
    header = "header.stamp.sec,header.stamp.nanosec,header.frame_id,name[0],position[0],velocity[0],effort"
    assert topic.csv_header(joint_state()) == header
    assert (
        topic.csv_header(command())
        == "layout.dim[0].label,layout.dim[0].size,layout.dim[0].stride,layout.data_offset,data[0]"
    )
    assert topic.csv_header(Float64MultiArray(data=[1.0, 2.0])) == "layout.dim,layout.data_offset,data[0],data[1]"
    for msg in (joint_state(), command(), Float64MultiArray(data=[1.0, 2.0])):  # a name for every cell
        assert len(topic.csv_header(msg).split(",")) == len(topic.message_to_csv(msg).split(","))


@pytest.mark.parametrize(
    ("typed", "current", "sent"),
    [
        ("60", DOUBLE_ARRAY, (DOUBLE_ARRAY, [60.0])),  # kp 60: a per-joint double array stays one
        ("60.5", DOUBLE_ARRAY, (DOUBLE_ARRAY, [60.5])),
        ("[70, 80]", DOUBLE_ARRAY, (DOUBLE_ARRAY, [70.0, 80.0])),
        ("-1", DOUBLE_ARRAY, (DOUBLE_ARRAY, [-1.0])),  # sent: the node is the judge
        ("100", DOUBLE, (DOUBLE, 100.0)),
        ("1e3", DOUBLE, (DOUBLE, 1000.0)),  # YAML 1.1 reads it as a string; a number is meant
        ("[]", DOUBLE_ARRAY, (DOUBLE_ARRAY, [])),
        ("60", None, (INTEGER, 60)),  # ros2 param set's own reading, where nothing says otherwise
        ("60", INTEGER, (INTEGER, 60)),
        ("60.0", None, (DOUBLE, 60.0)),
        ("[60.0]", None, (DOUBLE_ARRAY, [60.0])),
        ("[1, 2]", None, (INTEGER_ARRAY, [1, 2])),
        ("[1, 2.5]", None, (DOUBLE_ARRAY, [1.0, 2.5])),
        ("[1e4, 1e4, 1]", None, (DOUBLE_ARRAY, [1e4, 1e4, 1.0])),  # the 1e4s are numbers among numbers
        ("[1e4, 1e4, 1e0]", DOUBLE_ARRAY, (DOUBLE_ARRAY, [1e4, 1e4, 1.0])),
        ("[true, false]", None, (BOOL_ARRAY, [True, False])),
        ("[a, b]", None, (STRING_ARRAY, ["a", "b"])),
        ("true", None, (BOOL, True)),
        ("true", DOUBLE, (BOOL, True)),  # not a number: as typed, and the node refuses it
        ("lqr", STRING, (STRING, "lqr")),
        ("1e3", None, (STRING, "1e3")),
        ("a: b: c", None, (STRING, "a: b: c")),  # not YAML at all
        ("{a: 1}", None, (STRING, "{a: 1}")),
        ("", None, (STRING, "")),
    ],
)
def test_a_typed_value_is_read_as_ros2_param_set_reads_it_but_doubles_stay_doubles(typed, current, sent):
    kind, value = param.parse_value(typed, current)
    assert (kind, value) == sent
    assert type(value) is type(sent[1])
    if isinstance(value, list):
        assert [type(v) for v in value] == [type(v) for v in sent[1]]


@pytest.mark.parametrize(
    ("value", "line"),
    [
        (ParameterValue(type=DOUBLE_ARRAY, double_array_value=[60.0]), "Double array value is: [60.0]"),
        (ParameterValue(type=DOUBLE, double_value=60.0), "Double value is: 60.0"),
        (ParameterValue(type=INTEGER, integer_value=3), "Integer value is: 3"),
        (ParameterValue(type=STRING, string_value="lqr"), "String value is: lqr"),
        (ParameterValue(type=BOOL, bool_value=True), "Boolean value is: True"),
        (ParameterValue(type=STRING_ARRAY, string_array_value=["a"]), "String array value is: ['a']"),
        (ParameterValue(), "Parameter not set."),
    ],
)
def test_a_value_prints_as_ros2_param_get_prints_it(value, line):
    assert param.describe(value) == line


def test_a_dump_is_a_parameter_file_with_dotted_names_nested():
    values = {"kp": [60.0], "qos_overrides./x.depth": 10, "qos_overrides./x.history": "keep_last", "unset": None}
    document = param.dump_document("/pid_controller", values)
    assert document == {
        "/pid_controller": {
            "ros__parameters": {
                "kp": [60.0],
                "qos_overrides": {"/x": {"depth": 10, "history": "keep_last"}},
                "unset": None,
            }
        }
    }
    clash = param.dump_document("/n", {"a": 1, "a.b": 2})
    assert clash == {"/n": {"ros__parameters": {"a": 1, "a.b": 2}}}
    assert yaml.safe_load(yaml.safe_dump(document)) == document


def test_the_rate_is_ros2_topic_hz_s_two_lines_over_the_window_and_only_when_something_came():
    rate = topic.RateWindow(window=3)
    assert rate.report() is None
    for stamp_ms in (0, 10, 20, 32, 40):  # intervals 10, 10, 12, 8: the window keeps the last three
        rate.heard(stamp_ms * 1_000_000)
    assert rate.report() == ("average rate: 100.000\n\tmin: 0.008s max: 0.012s std dev: 0.00163s window: 3")
    assert rate.report() is None  # nothing new since
    rate.heard(35 * 1_000_000)  # the clock went back: counted, no interval
    rate.heard(45 * 1_000_000)
    assert rate.report().endswith("window: 3")


def test_importing_the_tools_loads_no_ros():
    """cli.py may import them eagerly: the CLI must stay fast."""
    code = (
        "import sys\nimport robot_controller.tools.topic, robot_controller.tools.param\n"
        "loaded = sorted(m for m in sys.modules if m.split('.')[0] in ('rclpy', 'rpyutils', 'yaml', 'numpy'))\n"
        "print(loaded)\nsys.exit(1 if loaded else 0)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert done.returncode == 0, done.stdout + done.stderr
