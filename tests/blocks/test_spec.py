"""The graph spec (``blocks.spec``): one port per topic, one type per topic, the recorder's, partition's and bag
reader's lists consistent, and no other module of the product spelling a topic name (so the rule stays kept)."""

import re
from pathlib import Path

import pytest
from rosbags.typesys import Stores, get_typestore

from robot_controller.blocks import spec

PRODUCT = Path(spec.__file__).resolve().parents[1]
SPEC_FILE = Path(spec.__file__).resolve()
# Quoted absolute paths that are files, not topics.
FILESYSTEM = ("/proc/", "/dev/", "/sys/", "/tmp/", "/nonexistent")
QUOTED_NAME = re.compile(r"""["'](/[a-z_]+(?:/[a-z_]+)*)["']""")


def _names() -> list[str]:
    """Every topic, service and action name of the spec, templates as their fixed tail (``/joint_trajectory``)."""
    names = [p.topic for p in spec.PORTS] + [s.service for s in spec.SERVICES] + [a.action for a in spec.ACTIONS]
    return [name.rpartition("}")[2] for name in names]


def _modules() -> list[Path]:
    return sorted(path for path in PRODUCT.rglob("*.py") if path.resolve() != SPEC_FILE)


def test_port_names_and_topics_are_unique():
    names = [p.name for p in spec.PORTS] + [s.name for s in spec.SERVICES] + [a.name for a in spec.ACTIONS]
    assert len(names) == len(set(names))
    topics = [p.topic for p in spec.PORTS]
    assert len(topics) == len(set(topics))


def test_no_two_ports_share_a_topic_with_different_types():
    types: dict[str, set[str]] = {}
    for port in spec.PORTS:
        types.setdefault(port.topic, set()).add(port.msg_type)
    assert {topic: t for topic, t in types.items() if len(t) > 1} == {}


@pytest.mark.parametrize("port", spec.PORTS, ids=lambda p: p.name)
def test_a_port_is_well_formed(port):
    assert re.fullmatch(r"(/(\{controller_name\}|[a-z_]+))+", port.topic), port.topic
    assert re.fullmatch(r"[a-z_]+/msg/[A-Z][A-Za-z0-9]*", port.msg_type), port.msg_type
    assert port.qos in spec.QOS_CLASSES and port.writer_qos in spec.QOS_CLASSES
    assert port.recorded in (spec.NEVER, spec.ALWAYS, spec.SIM_TIME)
    assert not port.public or port.partition  # written in the default partition *too*


def test_every_recorded_type_is_one_the_bag_reader_decodes():
    known = get_typestore(Stores.ROS2_JAZZY).fielddefs
    assert [p.msg_type for p in spec.recorded_ports(sim_time=True) if p.msg_type not in known] == []


def test_scoring_reads_only_what_is_recorded_or_was_in_old_bags():
    recorded = {p.topic for p in spec.recorded_ports(sim_time=True)}
    unrecorded = set(spec.scored_topics()) - recorded
    assert unrecorded == {spec.LEGACY_COMMAND_LATENCY.topic}
    assert spec.LEGACY_COMMAND_LATENCY not in spec.recorded_ports(sim_time=True)


def test_the_clock_is_recorded_in_sim_time_only():
    assert spec.CLOCK in spec.recorded_ports(sim_time=True)
    assert spec.CLOCK not in spec.recorded_ports(sim_time=False)


def test_the_estop_is_heard_from_anyone_and_the_loop_only_from_the_run():
    partition = spec.partition_topics()
    assert spec.ESTOP.topic not in partition and spec.ROSOUT.topic not in partition
    for port in (spec.READING, spec.TRUE_STATE, spec.REFERENCE, spec.COMMAND, spec.EFFORT, spec.BRAKES):
        assert port.topic in partition


def test_templates_take_the_controller_name():
    assert spec.CONTROLLER_WAYPOINTS.topic_for("arm") == "/arm/joint_trajectory"
    assert spec.FOLLOW_JOINT_TRAJECTORY.action_for("arm") == "/arm/follow_joint_trajectory"
    assert spec.READING.topic_for("arm") == spec.READING.topic


def test_port_lookup_names_the_known_ones():
    assert spec.port("reading") is spec.READING
    with pytest.raises(KeyError, match="reading"):
        spec.port("no_such_port")


def test_no_other_module_quotes_a_topic_like_name():
    found = [
        f"{path.relative_to(PRODUCT.parent)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(1)}"
        for path in _modules()
        for text in [path.read_text()]
        for m in QUOTED_NAME.finditer(text)
        if not m.group(1).startswith(FILESYSTEM)
    ]
    assert found == []


def test_no_other_module_spells_a_name_of_the_spec():
    """Docstrings, comments and log lines included: they name the port, or format the topic from the spec."""
    pattern = re.compile("|".join(rf"(?<![\w/]){re.escape(name)}(?![\w/])" for name in _names()))
    found = [
        f"{path.relative_to(PRODUCT.parent)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)}"
        for path in _modules()
        for text in [path.read_text()]
        for m in pattern.finditer(text)
    ]
    assert found == []
