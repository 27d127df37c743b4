"""The network bench's functional core, without namespaces or privilege: the
commands it would run, the loss rule, leftovers, the capability check, the report."""

import numpy as np
import pytest

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
        "messages": {
            "/sim/joint_states": {"recorded": 90, "published_here": 100, "lost": 10},
            "/trajectory": {"recorded": 1000},
            "/controller/state": {"recorded": 900},
        },
        "duration_s": 11.0,
        "braked_fraction": 0.2,
        "robot_exit": 0,
        "control_exit": 0,
    }
    text = report.render([entry], quick=False, started="today")
    assert "watchdog 5, brakes" in text and "/sim/joint_states 10" in text
    assert "**1 of 1 cases passed**" in text and text.rstrip().endswith("| yes |")
    assert report.document([entry], False, "today")["all_passed"]


RAN = {
    "split": "planner_remote",
    "condition": "clean",
    "robot_exit": 0,
    "control_exit": 0,
    "duration_s": 12.0,
    "band_deviation_rad": 0.001,
    "braked_fraction": 0.0,
    "messages": {"/trajectory": {"recorded": 1300}, "/controller/state": {"recorded": 1210}},
}


def _with(**changes):
    entry = dict(RAN, messages={t: dict(m) for t, m in RAN["messages"].items()})
    for key, value in changes.items():
        if key in ("trajectory", "ticks"):
            entry["messages"]["/trajectory" if key == "trajectory" else "/controller/state"]["recorded"] = value
        else:
            entry[key] = value
    return entry


def test_a_case_passes_only_if_the_loop_ran_and_kept_its_band():
    assert conditions.passed(RAN) and conditions.not_run(RAN) is None
    # The measured report counted these as passing (a still arm stays in its band): the loop never ran.
    no_plan = _with(trajectory=0, control_exit=1, band_deviation_rad=0.0054)  # planner remote, 500 kbit/s
    braked = _with(ticks=165, control_exit=1, band_deviation_rad=0.0, braked_fraction=0.9)  # controller remote
    assert conditions.not_run(no_plan) == "exit 0/1" and not conditions.passed(no_plan)
    assert conditions.not_run(_with(trajectory=0)) == "no plan arrived"
    assert conditions.not_run(_with(ticks=165)) == "165 controller ticks of 1200"
    assert conditions.not_run(_with(braked_fraction=0.9)) == "braked 90% of the time"
    assert not conditions.passed(braked) and not conditions.passed(_with(band_deviation_rad=0.2))
    # A run that ran and was judged FAILED (a cut link's stop) is the bench's to judge; one that failed is not run.
    judged = _with(robot_exit=1, verdict="failed", run_failure=None)
    assert conditions.not_run(judged) is None and conditions.passed(judged)
    crashed = _with(robot_exit=1, verdict="failed", run_failure="pid_controller died (exit code -9)")
    assert conditions.not_run(crashed) == "exit 1/0"
    doc = report.document([RAN, no_plan, braked], False, "today")
    assert doc["passed"] == 1 and not doc["all_passed"] and doc["worst_band_deviation_rad"] == 0.001
    text = report.render([RAN, no_plan, braked], quick=False, started="today")
    assert "**1 of 3 cases passed**" in text and "no: the loop did not run (exit 0/1)" in text


class _Recording:
    def __init__(self, brakes_time_s, brakes, last_tick_s):
        self.brakes_time_s, self.brakes = np.asarray(brakes_time_s), np.asarray(brakes, dtype=float)
        self.state = {"time_s": np.array([0.0, last_tick_s])}


def test_braked_fraction_holds_each_brake_sample_until_the_next():
    # Brakes off from 0 s, on from 4 s, off from 6 s; scored from 2 s to the last tick (10.1 s) less 0.1 s.
    recording = _Recording([0.0, 4.0, 6.0], [[0.0], [1.0], [0.0]], 10.1)
    assert conditions.braked_fraction(recording, 2.0) == pytest.approx(2.0 / 8.0)
    assert conditions.braked_fraction(_Recording([], np.zeros((0, 1)), 10.1), 2.0) is None
