"""Who may speak on the loop's topics: each run talks in a DDS partition of its own.

A ROS 2 subscriber takes messages from any publisher on its topic, and rclpy
(Jazzy) says nothing of who sent a message, so a stray or hostile peer on the
same domain (a second stack, a test publisher, a 5 kHz flood) used to be
obeyed. Fast DDS can put each reader and writer in named partitions (the
``partitions`` endpoint property, set per topic through an XML profile whose
name is the topic's): a writer and a reader match only when they share one.
The launcher writes a profile that puts every loop topic of its run in a
partition named for that run and hands it to every process it starts, so:

- the run's processes hear each other as before, and nothing else: a foreign
  publisher is never matched, so its messages never reach the loop (nor its
  CPU: a flood is not even sent to the run's readers);
- the graph still lists the foreign publisher (discovery is not partitioned),
  and the consumer names it in a warning;
- ``/estop``, ``/rosout``, parameter services stay open: anyone may stop the
  arm or change a parameter (which is checked as a whole configuration).

This is isolation, not security: partition names travel in clear in
discovery, and a peer that copies one is heard. Authentication needs
DDS-Security, which the PyPI Fast DDS is built without.

An observer that should hear every run (the tests' probe, a viewer) uses
``write_observer_profile``: it reads from and writes into the default
partition and every named one.
"""

from __future__ import annotations

import copy
import secrets
import xml.etree.ElementTree as ET
from pathlib import Path

from robot_controller import resources

# Every topic the stack's nodes publish or consume to run the loop; /estop is
# deliberately left out (a stop must be heard from anyone).
LOOP_TOPICS = (
    "/trajectory",
    "/joint_states",
    "/joint_commands",
    "/sim/effort",
    "/sim/joint_states",
    "/sim/brake",
    "/sim/brakes",
    "/controller/state",
    "/motor/command_receipts",
    "/diagnostics",
    "/clock",
    "/sim/disturbance",
    "/sim/disturbance_applied",
    # A command that moves the arm: heard from the run and the project's tools (observer profile) only.
    "/trajectory_planner/joint_trajectory",
)

#: Set by the launcher in each node's environment: the run's partition name.
PARTITION_ENV = "ROBOT_CONTROLLER_PARTITION"
#: Fast DDS reads its XML profiles from this file when a process creates its first participant.
PROFILES_ENV = "FASTRTPS_DEFAULT_PROFILES_FILE"

_NS = "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"
# "" is the default partition (every peer that sets none); "*" matches every named one.
_EVERY_PARTITION_READER = ";*"
_EVERY_PARTITION_WRITER = ";*"


def new_partition() -> str:
    return f"robot_controller_{secrets.token_hex(6)}"


def write_run_profile(path: Path, partition: str, base: Path | None = None) -> Path:
    """The stack's Fast DDS profile (``config/fastdds.xml``) with every loop topic in ``partition``."""
    return _write(path, base, writer_partitions=partition, reader_partitions=partition)


def write_observer_profile(path: Path, base: Path | None = None) -> Path:
    """A profile for a process that should hear every run and the default partition alike."""
    return _write(path, base, writer_partitions=_EVERY_PARTITION_WRITER, reader_partitions=_EVERY_PARTITION_READER)


def _write(path: Path, base: Path | None, *, writer_partitions: str, reader_partitions: str) -> Path:
    ET.register_namespace("", _NS)
    tree = ET.parse(base or resources.fastdds_profiles())
    root = tree.getroot()
    # A profile named for a topic replaces the default profile for that topic
    # (unset fields take Fast DDS's defaults, not the default profile's), so
    # each starts as a copy of the default one.
    for kind, partitions in (("data_writer", writer_partitions), ("data_reader", reader_partitions)):
        default = next((e for e in root.findall(f"{{{_NS}}}{kind}") if e.get("is_default_profile") == "true"), None)
        for topic in LOOP_TOPICS:
            profile = copy.deepcopy(default) if default is not None else ET.Element(f"{{{_NS}}}{kind}")
            profile.attrib = {"profile_name": topic}
            _set_property(profile, "partitions", partitions)
            root.append(profile)
    path.parent.mkdir(parents=True, exist_ok=True)
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    return path


def _set_property(profile: ET.Element, name: str, value: str) -> None:
    policy = profile.find(f"{{{_NS}}}propertiesPolicy")
    if policy is None:
        policy = ET.SubElement(profile, f"{{{_NS}}}propertiesPolicy")
    properties = policy.find(f"{{{_NS}}}properties")
    if properties is None:
        properties = ET.SubElement(policy, f"{{{_NS}}}properties")
    prop = ET.SubElement(properties, f"{{{_NS}}}property")
    ET.SubElement(prop, f"{{{_NS}}}name").text = name
    ET.SubElement(prop, f"{{{_NS}}}value").text = value
