"""Who may speak on the loop's topics: each run's Fast DDS profile puts its loop topics in a partition named for the
run, so a foreign publisher is never matched (isolation, not security); the e-stop, the log and parameter services stay
open; ``write_observer_profile`` hears every run. Across hosts (``--peers``, docs/design.md §6) participants speak
UDPv4 only (netns share ``/dev/shm``), listen only on loopback and the address that reaches the peers, and discover by
unicast from their ``initialPeersList``."""

from __future__ import annotations

import copy
import hashlib
import ipaddress
import re
import secrets
import socket
import xml.etree.ElementTree as ET
from pathlib import Path

from robot_controller import resources
from robot_controller.blocks import spec
from robot_controller.core.errors import ConfigError

# Every topic the nodes use to run the loop (``blocks.spec``'s partition ports); not the e-stop (a stop must be heard
# from anyone).
LOOP_TOPICS = spec.partition_topics()
#: Loop topics any ROS client may also hear: written in the run's partition and the default one, read in the run's
#: only (a foreign publisher of them is never heard): the readings, and the paced world's clock for clients on
#: use_sim_time. The rest of the arm's public face is outside every partition: the FollowJointTrajectory action, the
#: controller's waypoints topic, the robot description, the e-stop.
PUBLISHED_TOO = spec.public_topics()

#: Set by the launcher in each node's environment: the run's partition name.
PARTITION_ENV = "ROBOT_CONTROLLER_PARTITION"
#: Fast DDS reads its XML profiles from this file when a process creates its first participant.
PROFILES_ENV = "FASTRTPS_DEFAULT_PROFILES_FILE"

_NS = "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"
# "" is the default partition (every peer that sets none); "*" matches every named one.
_EVERY_PARTITION = ";*"

# Participant ids whose discovery ports an initial peer is sent to, on every announcement (a datagram each): two
# participants meet when either one's id is below it, so it covers one side, a launcher's processes and a few tools.
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
    """The partition of the run named ``run_id``: the same on every host that names it, a different one for every other
    name (and never one of :func:`new_partition`'s, hex of a hash, not of chance, though of the same form)."""
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
    """The stack's Fast DDS profile (``config/fastdds.xml``) with every loop topic in ``partition`` (written in the
    default one too for :data:`PUBLISHED_TOO`). ``peers``: a run across hosts: UDPv4 only, those addresses as initial
    peers (module docstring)."""
    return _write(path, base, partition, peers=peers, public_writers=f";{partition}")


def write_observer_profile(path: Path, base: Path | None = None, *, loopback_udp: bool = False) -> Path:
    """A profile for a process that should hear every run and the default partition alike; ``loopback_udp``: speaking
    UDP on this host's loopback only, no shared memory (a short-lived tool: see ``tools.graph``)."""
    return _write(path, base, _EVERY_PARTITION, peers=[LOCALHOST] if loopback_udp else None)


def _write(
    path: Path, base: Path | None, partitions: str, *, peers: list[str] | None = None, public_writers: str | None = None
) -> Path:
    ET.register_namespace("", _NS)
    tree = ET.parse(base or resources.fastdds_profiles())
    root = tree.getroot()
    if peers:
        _udp_only(root, peers)
    # A topic's profile replaces the default one (unset fields take Fast DDS's defaults): start from a copy of it.
    for kind in ("data_writer", "data_reader"):
        default = next((e for e in root.findall(f"{{{_NS}}}{kind}") if e.get("is_default_profile") == "true"), None)
        for topic in LOOP_TOPICS:
            profile = copy.deepcopy(default) if default is not None else ET.Element(f"{{{_NS}}}{kind}")
            profile.attrib = {"profile_name": topic}
            public = kind == "data_writer" and topic in PUBLISHED_TOO and public_writers is not None
            _set_property(profile, "partitions", public_writers if public else partitions)
            if peers:
                _no_data_sharing(profile)
            root.append(profile)
    path.parent.mkdir(parents=True, exist_ok=True)
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    return path


def _child(parent: ET.Element, tag: str, *, first: bool = False) -> ET.Element:
    """``parent``'s ``tag`` element, made if missing (``first``: made as its first child, as the schema orders it)."""
    found = parent.find(f"{{{_NS}}}{tag}")
    if found is None:
        found = ET.Element(f"{{{_NS}}}{tag}")
        parent.insert(0 if first else len(parent), found)
    return found


def _udp_only(root: ET.Element, peers: list[str]) -> None:
    """One UDPv4 transport, no builtin ones (no shared memory), on the default participant; ``peers`` initial."""
    descriptors = _child(root, "transport_descriptors", first=True)
    descriptor = ET.SubElement(descriptors, f"{{{_NS}}}transport_descriptor")
    ET.SubElement(descriptor, f"{{{_NS}}}transport_id").text = UDP_TRANSPORT_ID
    ET.SubElement(descriptor, f"{{{_NS}}}type").text = "UDPv4"
    ET.SubElement(descriptor, f"{{{_NS}}}maxInitialPeersRange").text = str(MAX_INITIAL_PEERS_RANGE)
    allowed = ET.SubElement(descriptor, f"{{{_NS}}}interfaceWhiteList")  # sockets bound to these, not to every one
    for address in listening_addresses(peers):
        ET.SubElement(allowed, f"{{{_NS}}}address").text = address
    participant = next(
        (e for e in root.findall(f"{{{_NS}}}participant") if e.get("is_default_profile") == "true"), None
    )
    if participant is None:
        attributes = {"profile_name": "robot_controller_participant", "is_default_profile": "true"}
        participant = ET.SubElement(root, f"{{{_NS}}}participant", attributes)
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
    # Discovery by unicast only: a unicast metatraffic locator of any address and port (Fast DDS fills it in) keeps
    # it from making its default multicast one; announcements go to the initial peers.
    unicast = _child(builtin, "metatrafficUnicastLocatorList")
    ET.SubElement(ET.SubElement(unicast, f"{{{_NS}}}locator"), f"{{{_NS}}}udpv4")
    initial = _child(builtin, "initialPeersList")
    for peer in [LOCALHOST, *(p for p in peers if p != LOCALHOST)]:
        locator = ET.SubElement(initial, f"{{{_NS}}}locator")
        ET.SubElement(ET.SubElement(locator, f"{{{_NS}}}udpv4"), f"{{{_NS}}}address").text = peer


def listening_addresses(peers: list[str]) -> list[str]:
    """The addresses a run across hosts listens on: loopback and this host's address on the way to each peer."""
    return list(dict.fromkeys([LOCALHOST, *(route_source(peer) for peer in peers)]))


def route_source(peer: str) -> str:
    """The address this host sends to ``peer`` from, as ``ip route get`` gives it (a UDP connect sends nothing)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect((peer, 9))
        except OSError as exc:
            raise ConfigError(f"--peers: no route from this host to {peer} ({exc.strerror})") from None
        return probe.getsockname()[0]


def _slow_announcements(builtin: ET.Element) -> None:
    """Periodic participant announcements every :data:`SPLIT_ANNOUNCEMENT_PERIOD_S` instead of the base's 0.5 s:
    each goes to every initial peer's discovery ports. The fast initial announcements stay, and a participant
    answers a newly discovered one at once, so a late launcher is still seen in under a second."""
    period = _child(_child(builtin, "discovery_config", first=True), "leaseAnnouncement")
    for child in list(period):
        period.remove(child)
    ET.SubElement(period, f"{{{_NS}}}sec").text = str(int(SPLIT_ANNOUNCEMENT_PERIOD_S))
    ET.SubElement(period, f"{{{_NS}}}nanosec").text = str(round(SPLIT_ANNOUNCEMENT_PERIOD_S % 1 * 1e9))


def _no_data_sharing(profile: ET.Element) -> None:
    """Data-sharing delivery off: like shared memory, it would bypass the network between namespaces."""
    _child(_child(_child(profile, "qos"), "data_sharing"), "kind").text = "OFF"


def _set_property(profile: ET.Element, name: str, value: str) -> None:
    prop = ET.SubElement(_child(_child(profile, "propertiesPolicy"), "properties"), f"{{{_NS}}}property")
    ET.SubElement(prop, f"{{{_NS}}}name").text = name
    ET.SubElement(prop, f"{{{_NS}}}value").text = value
