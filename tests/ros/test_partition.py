"""The run's Fast DDS profile across hosts listens only on loopback and the address that reaches the
peers (an interface allow-list on its one UDPv4 transport); a peer with no route is refused in one line."""

import errno
import socket
import xml.etree.ElementTree as ET

import pytest

from robot_controller.blocks import spec
from robot_controller.core.errors import ConfigError
from robot_controller.ros import partition

NS = {"p": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def test_across_hosts_the_transport_listens_on_loopback_and_the_way_to_the_peers_only(tmp_path, monkeypatch):
    routes = {"10.203.0.2": "10.203.0.1", "10.203.0.3": "10.203.0.1", "10.9.0.7": "10.9.0.1"}
    monkeypatch.setattr(partition, "route_source", routes.__getitem__)
    path = partition.write_run_profile(tmp_path / "fastdds.xml", "robot_controller_0123456789ab", peers=list(routes))
    root = ET.parse(path).getroot()
    [descriptor] = root.findall("p:transport_descriptors/p:transport_descriptor", NS)
    allowed = [a.text for a in descriptor.findall("p:interfaceWhiteList/p:address", NS)]
    assert allowed == ["127.0.0.1", "10.203.0.1", "10.9.0.1"]  # once each
    # ... on the transport the participant uses, the only one it has.
    [participant] = [p for p in root.findall("p:participant", NS) if p.get("is_default_profile") == "true"]
    used = [t.text for t in participant.findall("p:rtps/p:userTransports/p:transport_id", NS)]
    assert used == [descriptor.findtext("p:transport_id", namespaces=NS)]
    assert participant.findtext("p:rtps/p:useBuiltinTransports", namespaces=NS) == "false"


def test_on_one_host_no_allow_list_is_written(tmp_path):
    text = partition.write_run_profile(tmp_path / "fastdds.xml", "robot_controller_0123456789ab").read_text()
    assert "interfaceWhiteList" not in text


def test_the_address_toward_a_peer_is_the_kernels_route():
    assert partition.route_source("127.0.0.1") == "127.0.0.1"
    assert partition.listening_addresses(["127.0.0.1"]) == ["127.0.0.1"]


def test_a_peer_this_host_has_no_route_to_is_refused_naming_it(monkeypatch):
    class Unroutable(socket.socket):
        def connect(self, address):
            raise OSError(errno.ENETUNREACH, "Network is unreachable")

    monkeypatch.setattr(partition.socket, "socket", Unroutable)
    with pytest.raises(
        ConfigError, match=r"^--peers: no route from this host to 10\.203\.0\.2 \(Network is unreachable\)$"
    ):
        partition.route_source("10.203.0.2")


def test_every_port_of_the_partition_has_a_profile_and_the_public_ones_are_written_outside_it_too(tmp_path):
    root = ET.parse(partition.write_run_profile(tmp_path / "fastdds.xml", "robot_controller_0123456789ab")).getroot()

    def partitions(kind: str) -> dict[str, str]:
        return {
            e.get("profile_name"): e.findtext("p:propertiesPolicy/p:properties/p:property/p:value", namespaces=NS)
            for e in root.findall(f"p:{kind}", NS)
            if e.get("profile_name", "").startswith("/")
        }

    writers, readers = partitions("data_writer"), partitions("data_reader")
    assert set(writers) == set(readers) == set(spec.partition_topics())
    assert spec.ESTOP.topic not in writers
    assert {t for t, p in writers.items() if p.startswith(";")} == {spec.READING.topic, spec.CLOCK.topic}
    assert set(readers.values()) == {"robot_controller_0123456789ab"}
