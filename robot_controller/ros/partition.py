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

**Across hosts** (``run --peers``, docs/design.md §6 "Across hosts"): each
launcher of a split run derives the partition from the run's name
(:func:`run_partition`), so both sides meet in one partition without
exchanging anything, and the profile (:func:`write_run_profile` with
``peers``) makes the participants speak UDPv4 only, and discover by unicast:

- the builtin transports are disabled (``<useBuiltinTransports>false``) and
  one UDPv4 transport is declared (``<transport_descriptors>`` and
  ``<userTransports>``): Fast DDS would otherwise use shared memory between
  participants it believes share a host, and two network namespaces of one
  machine do share ``/dev/shm``, so a "remote" link would silently bypass
  the network under test. Data-sharing delivery is switched off on every
  loop topic's reader and writer for the same reason;
- the peers' addresses are the participant's ``initialPeersList`` (without a
  port: Fast DDS tries the discovery ports of participant ids 0 to
  ``maxInitialPeersRange`` − 1, 12: one launcher's processes and a few tools),
  and the participants announce themselves every 3 s once started, not every
  0.5 s: each announcement goes to all those ports of every peer, and at 32
  ports and 0.5 s discovery was most of what crossed the link. With ``ROS_AUTOMATIC_DISCOVERY_RANGE=
  LOCALHOST`` (the launcher sets it) rmw_fastrtps clears the multicast
  locators and adds 127.0.0.1 to the peers: no multicast at all, discovery
  goes only to this host and the named peers.
"""

from __future__ import annotations

import copy
import hashlib
import ipaddress
import re
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


# Participant ids whose discovery ports an initial peer is sent to, on every announcement, found or not.
# Two participants meet when either one's id is below it (the other hears it and answers at once), so it
# need only cover one side: a launcher's own processes (the recorder, its nodes, a watcher: 6 at most) and
# a few tools. Each port costs: at 32, one participant's announcement was a 14 KB burst of 32 datagrams,
# more than a 2 Mbit/s link queues in 50 ms (docs/network.md, "What crosses the link").
MAX_INITIAL_PEERS_RANGE = 12
#: With ``--peers``: the participants' periodic announcement (Fast DDS's default; the lease is 20 s).
SPLIT_ANNOUNCEMENT_PERIOD_S = 3.0
UDP_TRANSPORT_ID = "robot_controller_udpv4"
LOCALHOST = "127.0.0.1"
#: With ``--peers`` the profile says how discovery goes; rmw_fastrtps must leave it alone (with
#: ``LOCALHOST`` it would add its own shared-memory transport, SUBNET would multicast).
PEERS_DISCOVERY_RANGE = "SYSTEM_DEFAULT"
#: Set in every node's environment when the loop is split across hosts: its readers are best effort (ros.qos).
LOOP_QOS_ENV = "ROBOT_CONTROLLER_LOOP_QOS"
_RUN_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def new_partition() -> str:
    return f"robot_controller_{secrets.token_hex(6)}"


def check_run_id(run_id: str) -> str:
    """``run_id`` as given, or ValueError: 1-64 letters, digits, ``_.-``, starting with a letter or digit."""
    if not _RUN_ID.fullmatch(run_id):
        raise ValueError(f"run id {run_id!r}: 1-64 letters, digits, '_', '.', '-', starting with a letter or digit")
    return run_id


def run_partition(run_id: str) -> str:
    """The partition of the run named ``run_id``: the same on every host that names it, a
    different one for every other name (and never one of :func:`new_partition`'s, hex of
    a hash, not of chance, though of the same form)."""
    return f"robot_controller_{hashlib.sha256(check_run_id(run_id).encode()).hexdigest()[:12]}"


def check_peers(text: str) -> list[str]:
    """``"10.203.0.2,10.203.0.3"`` → the addresses, or ValueError naming the bad one (IPv4 only, unicast)."""
    peers = [part.strip() for part in text.split(",")]
    for peer in peers:
        try:
            address = ipaddress.IPv4Address(peer)
        except ValueError:
            raise ValueError(f"peer {peer!r} is not an IPv4 address") from None
        if address.is_multicast or address.is_unspecified or peer == "255.255.255.255":
            raise ValueError(f"peer {peer}: a host's unicast address is needed")
    if len(set(peers)) != len(peers):
        raise ValueError(f"peers repeat an address: {text}")
    return peers


def write_run_profile(path: Path, partition: str, base: Path | None = None, peers: list[str] | None = None) -> Path:
    """The stack's Fast DDS profile (``config/fastdds.xml``) with every loop topic in ``partition``.
    ``peers``: a run across hosts: UDPv4 only, those addresses as initial peers (module docstring)."""
    return _write(path, base, writer_partitions=partition, reader_partitions=partition, peers=peers)


def write_observer_profile(path: Path, base: Path | None = None) -> Path:
    """A profile for a process that should hear every run and the default partition alike."""
    return _write(path, base, writer_partitions=_EVERY_PARTITION_WRITER, reader_partitions=_EVERY_PARTITION_READER)


def _write(
    path: Path, base: Path | None, *, writer_partitions: str, reader_partitions: str, peers: list[str] | None = None
) -> Path:
    ET.register_namespace("", _NS)
    tree = ET.parse(base or resources.fastdds_profiles())
    root = tree.getroot()
    if peers:
        _udp_only(root, peers)
    # A profile named for a topic replaces the default profile for that topic
    # (unset fields take Fast DDS's defaults, not the default profile's), so
    # each starts as a copy of the default one.
    for kind, partitions in (("data_writer", writer_partitions), ("data_reader", reader_partitions)):
        default = next((e for e in root.findall(f"{{{_NS}}}{kind}") if e.get("is_default_profile") == "true"), None)
        for topic in LOOP_TOPICS:
            profile = copy.deepcopy(default) if default is not None else ET.Element(f"{{{_NS}}}{kind}")
            profile.attrib = {"profile_name": topic}
            _set_property(profile, "partitions", partitions)
            if peers:
                _no_data_sharing(profile)
            root.append(profile)
    path.parent.mkdir(parents=True, exist_ok=True)
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    return path


def _child(parent: ET.Element, tag: str) -> ET.Element:
    """``parent``'s ``tag`` element, made if missing."""
    found = parent.find(f"{{{_NS}}}{tag}")
    return found if found is not None else ET.SubElement(parent, f"{{{_NS}}}{tag}")


def _udp_only(root: ET.Element, peers: list[str]) -> None:
    """One UDPv4 transport and no builtin ones (so no shared memory) on the default
    participant profile, with ``peers`` as its initial peers."""
    descriptors = root.find(f"{{{_NS}}}transport_descriptors")
    if descriptors is None:
        descriptors = ET.Element(f"{{{_NS}}}transport_descriptors")
        root.insert(0, descriptors)  # the schema wants the descriptors before the profiles that name them
    descriptor = ET.SubElement(descriptors, f"{{{_NS}}}transport_descriptor")
    ET.SubElement(descriptor, f"{{{_NS}}}transport_id").text = UDP_TRANSPORT_ID
    ET.SubElement(descriptor, f"{{{_NS}}}type").text = "UDPv4"
    ET.SubElement(descriptor, f"{{{_NS}}}maxInitialPeersRange").text = str(MAX_INITIAL_PEERS_RANGE)
    participant = next(
        (e for e in root.findall(f"{{{_NS}}}participant") if e.get("is_default_profile") == "true"), None
    )
    if participant is None:
        participant = ET.SubElement(root, f"{{{_NS}}}participant", {"profile_name": "robot_controller_participant"})
        participant.set("is_default_profile", "true")
    rtps = _child(participant, "rtps")
    # The schema's order inside <rtps>: the transports before <builtin>.
    transports = ET.Element(f"{{{_NS}}}userTransports")
    ET.SubElement(transports, f"{{{_NS}}}transport_id").text = UDP_TRANSPORT_ID
    builtin_off = ET.Element(f"{{{_NS}}}useBuiltinTransports")
    builtin_off.text = "false"
    rtps.insert(0, builtin_off)
    rtps.insert(0, transports)
    builtin = _child(rtps, "builtin")
    _slow_announcements(builtin)
    # Discovery by unicast only: a unicast metatraffic locator of any address and port (what
    # Fast DDS fills in itself) keeps it from making its default multicast one (as rmw_fastrtps
    # does for LOCALHOST); announcements go to the initial peers.
    unicast = _child(builtin, "metatrafficUnicastLocatorList")
    ET.SubElement(ET.SubElement(unicast, f"{{{_NS}}}locator"), f"{{{_NS}}}udpv4")
    initial = _child(builtin, "initialPeersList")
    for peer in [LOCALHOST, *(p for p in peers if p != LOCALHOST)]:
        locator = ET.SubElement(initial, f"{{{_NS}}}locator")
        ET.SubElement(ET.SubElement(locator, f"{{{_NS}}}udpv4"), f"{{{_NS}}}address").text = peer


def _slow_announcements(builtin: ET.Element) -> None:
    """Periodic participant announcements every :data:`SPLIT_ANNOUNCEMENT_PERIOD_S` instead of the base's 0.5 s.

    Each announcement goes to every initial peer's ``maxInitialPeersRange`` discovery ports, discovered or not:
    at 0.5 s the robot host's six participants sent 6 × 2/s × 32 ports of ~400 B, 1.2 Mbit/s of discovery
    across the link, two thirds of what it carried (docs/network.md, "What crosses the link"). The fast
    initial announcements stay; a participant that discovers a new one answers it at once (Fast DDS sends
    its announcement to a newly matched participant), so a late launcher is still seen in under a second."""
    discovery = builtin.find(f"{{{_NS}}}discovery_config")
    if discovery is None:
        discovery = ET.Element(f"{{{_NS}}}discovery_config")
        builtin.insert(0, discovery)  # the schema's order: <discovery_config> first in <builtin>
    period = discovery.find(f"{{{_NS}}}leaseAnnouncement")
    if period is None:
        period = ET.SubElement(discovery, f"{{{_NS}}}leaseAnnouncement")
    for child in list(period):
        period.remove(child)
    ET.SubElement(period, f"{{{_NS}}}sec").text = str(int(SPLIT_ANNOUNCEMENT_PERIOD_S))
    ET.SubElement(period, f"{{{_NS}}}nanosec").text = str(round(SPLIT_ANNOUNCEMENT_PERIOD_S % 1 * 1e9))


def _no_data_sharing(profile: ET.Element) -> None:
    """Data-sharing delivery off: like shared memory, it would bypass the network between namespaces."""
    kind = _child(_child(_child(profile, "qos"), "data_sharing"), "kind")
    kind.text = "OFF"


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
