"""``run --nodes/--peers/--run-id`` without ROS: the run's Fast DDS profile
across hosts, the partition a run id names, and the refusals (one line, exit 2)."""

import xml.etree.ElementTree as ET

import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.nodes import graph_watch
from robot_controller.ros import partition
from robot_controller.runner import plan as run_plan
from robot_controller.runner.options import RunOptions, check_nodes
from robot_controller.runner.supervise import GraphLink
from tests.cli.test_errors import cli, one_line_error

NS = {"p": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def test_the_profile_across_hosts_is_udp_only_with_the_peers(tmp_path, monkeypatch):
    monkeypatch.setattr(partition, "route_source", lambda peer: "10.203.0.1")  # whatever this host's routes are
    path = partition.write_run_profile(
        tmp_path / "fastdds.xml", partition.run_partition("r1"), peers=["10.203.0.2", "10.203.0.3"]
    )
    root = ET.parse(path).getroot()
    [descriptor] = root.findall("p:transport_descriptors/p:transport_descriptor", NS)
    assert descriptor.findtext("p:type", namespaces=NS) == "UDPv4"
    transport_id = descriptor.findtext("p:transport_id", namespaces=NS)
    [participant] = [p for p in root.findall("p:participant", NS) if p.get("is_default_profile") == "true"]
    rtps = participant.find("p:rtps", NS)
    assert rtps.findtext("p:useBuiltinTransports", namespaces=NS) == "false"  # no shared memory
    assert [t.text for t in rtps.findall("p:userTransports/p:transport_id", NS)] == [transport_id]
    peers = [a.text for a in rtps.findall("p:builtin/p:initialPeersList/p:locator/p:udpv4/p:address", NS)]
    assert peers == ["127.0.0.1", "10.203.0.2", "10.203.0.3"]
    # A unicast discovery locator and no multicast one: discovery only to the peers.
    assert rtps.find("p:builtin/p:metatrafficUnicastLocatorList/p:locator/p:udpv4", NS) is not None
    assert rtps.find("p:builtin/p:metatrafficMulticastLocatorList", NS) is None
    # Every loop topic in the run's partition, data-sharing off.
    for kind in ("data_writer", "data_reader"):
        profiles = {p.get("profile_name"): p for p in root.findall(f"p:{kind}", NS)}
        for topic in partition.LOOP_TOPICS:
            assert profiles[topic].findtext("p:qos/p:data_sharing/p:kind", namespaces=NS) == "OFF"
            values = profiles[topic].findall("p:propertiesPolicy/p:properties/p:property/p:value", NS)
            # (A writer of the public face's topics writes into the default partition "" too.)
            assert partition.run_partition("r1") in [p for v in values for p in v.text.split(";")]


def test_the_single_host_profile_is_unchanged(tmp_path):
    text = partition.write_run_profile(tmp_path / "fastdds.xml", "robot_controller_0123456789ab").read_text()
    assert "useBuiltinTransports" not in text and "initialPeersList" not in text and "data_sharing" not in text


def test_a_run_id_names_one_partition():
    assert partition.run_partition("bench-1") == partition.run_partition("bench-1")
    assert partition.run_partition("bench-1") != partition.run_partition("bench-2")
    assert partition.run_partition("bench-1").startswith("robot_controller_")


@pytest.mark.parametrize("text", ["", "a b", "-x", "x" * 65, "a/b"])
def test_bad_run_ids_are_refused(text):
    with pytest.raises(ValueError):
        partition.check_run_id(text)


@pytest.mark.parametrize("text", ["10.0.0", "host.example", "239.255.0.1", "0.0.0.0", "10.0.0.1,10.0.0.1"])
def test_bad_peers_are_refused(text):
    with pytest.raises(ValueError):
        partition.check_peers(text)


def test_nodes_are_put_in_the_graphs_order():
    assert check_nodes("trajectory_planner, simulator") == ("simulator", "trajectory_planner")


@pytest.mark.parametrize(
    "args, expected",
    [
        (["--nodes", "simulator,planner"], "unknown node(s) 'planner'"),
        (["--nodes", "simulator,simulator"], "named twice"),
        (["--peers", "10.203.0"], "not an IPv4 address"),
        (["--run-id", "two words"], "run id"),
        (["--nodes", "trajectory_planner"], "needs --run-id"),
        (["--nodes", "trajectory_planner", "--run-id", "x", "--single-process"], "cannot take --nodes"),
        (["--wait", "0"], "must be a finite number > 0"),
    ],
)
def test_split_options_refused_in_one_line(tmp_path, args, expected):
    one_line_error(cli("run", "--duration", "1", "--out", str(tmp_path / "run"), *args), expected)


def test_a_profile_of_the_users_cannot_carry_the_run_id(tmp_path, monkeypatch):
    monkeypatch.setenv(partition.PROFILES_ENV, str(tmp_path / "mine.xml"))
    with pytest.raises(ConfigError, match="unset it"):
        run_plan.check({}, RunOptions(run_id="x"))


def test_the_other_side_has_ended_once_all_its_nodes_have_left(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr("robot_controller.runner.supervise.time.monotonic", lambda: clock[0])
    graph = GraphLink()
    remote = ("simulator", "pid_controller")
    assert graph.on_line(graph_watch.report_line(["simulator", "pid_controller", "trajectory_planner"]))
    assert graph.missing(("simulator", "trajectory_planner", "motor_node")) == ["motor_node"]
    assert not graph.all_gone(remote)
    graph.on_line(graph_watch.report_line(["pid_controller", "trajectory_planner"]))  # one respawns
    clock[0] += 5
    assert not graph.all_gone(remote)
    graph.on_line(graph_watch.report_line(["trajectory_planner"]))
    clock[0] += 0.5
    assert not graph.all_gone(remote)  # not gone for long enough yet
    clock[0] += 0.6
    assert graph.all_gone(remote)
    assert not graph.on_line("[INFO] anything else")
