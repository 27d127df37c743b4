"""The network bench's functional core, without namespaces or privilege: the
commands it would run, the loss rule, leftovers, the capability check, the report."""

from robot_controller_lab.network import conditions, netns, report


def test_setup_makes_both_namespaces_and_a_veth_that_never_exists_outside_them():
    robot, control = netns.hosts(pid=42)
    assert (robot.namespace, control.namespace) == ("rcnet-42-robot", "rcnet-42-control")
    commands = netns.setup_commands(robot, control)
    veth = next(c for c in commands if "veth" in c)
    assert veth[veth.index("netns") + 1] == robot.namespace
    assert veth[-1] == control.namespace  # the peer is created inside the control namespace
    addresses = [c for c in commands if "addr" in c]
    assert [c[c.index("add") + 1] for c in addresses] == ["10.203.0.1/24", "10.203.0.2/24"]
    assert ["ip", "-n", robot.namespace, "link", "set", "lo", "up"] in commands
    teardown = netns.teardown_commands(robot, control)
    assert teardown[-2:] == [["ip", "netns", "del", robot.namespace], ["ip", "netns", "del", control.namespace]]


def test_loss_drops_on_arrival_in_the_benchs_own_table():
    script = netns.loss_ruleset("rc-robot", 5)
    assert f"table inet {netns.TABLE}" in script
    assert "hook input" in script  # on arrival: a drop on output fails the sender's sendto (EPERM)
    assert 'iifname "rc-robot" numgen random mod 100 < 5 counter drop' in script


def test_leftovers_are_only_the_benchs_namespaces_of_dead_processes():
    listing = "rcnet-7-robot (id: 3)\nrcnet-7-control\nrcnet-8-robot\nsomeone-else\nrcnet-x-robot\n"
    assert netns.leftover_namespaces(listing, alive={8}) == ["rcnet-7-robot", "rcnet-7-control"]


def test_capability_check_reads_the_effective_set():
    assert netns.has_net_admin("Name:\tx\nCapEff:\t000001ffffffffff\n")
    assert not netns.has_net_admin("CapEff:\t0000000000000000\n")
    assert not netns.has_net_admin("CapEff:\t" + format(0xFFFF & ~(1 << 12), "016x") + "\n")


def test_splits_cover_the_graph_and_quick_is_a_subset():
    for split in conditions.SPLITS:
        assert sorted(split.robot_nodes + split.control_nodes) == sorted(conditions.ALL_NODES)
        assert "simulator" in split.robot_nodes
    assert len(conditions.runs(quick=True)) < len(conditions.runs(quick=False))


def test_report_names_reactions_and_lost_messages():
    entry = {
        "split": "controller_remote",
        "condition": "cut_2",
        "tracking_rms_rad": 0.02,
        "tracking_max_rad": 0.2,
        "band_deviation_rad": 0.003,
        "reacquire_s": 0.6,
        "watchdog_ticks": 5,
        "brakes_engaged": True,
        "messages": {"/sim/joint_states": {"recorded": 90, "published_here": 100, "lost": 10}},
        "robot_exit": 0,
        "control_exit": 0,
    }
    text = report.render([entry], quick=False, started="today")
    assert "watchdog 5, brakes" in text and "/sim/joint_states 10" in text
    assert report.document([entry], False, "today")["all_within_goal"]
