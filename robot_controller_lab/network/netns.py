"""Two hosts on one machine: network namespaces joined by a veth pair, their
lifetime, and the commands run inside them.

The "robot host" (10.203.0.1/24) and the "control host" (10.203.0.2/24) are
two network namespaces, each with its loopback up and one end of a veth
pair; nothing else is routed, so whatever runs inside them can reach only
the other one. The link's loss, bandwidth cap and cuts are ``impairments``;
the hosts' names and addresses are ``hosts``.

Everything is created under names carrying this process's id and removed on
exit, on Ctrl-C or SIGTERM and on an error (``Link`` is a context manager;
the processes started in the namespaces are stopped first, since a process
keeps its namespace alive). A namespace left by an earlier run that was
killed (its process id no longer alive) is removed before anything is made.

The command builders are plain functions of their arguments; ``Link`` runs them.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

from robot_controller.runner.forking import die_with_parent
from robot_controller_lab.network.hosts import NAME_PREFIX, PREFIX_LENGTH, Host, hosts, in_namespace
from robot_controller_lab.network.hosts import run as _run
from robot_controller_lab.network.impairments import (
    TABLE,
    Impairments,
    clear_commands,
    link_command,
    loss_commands,
    loss_ruleset,
    rate_command,
)

__all__ = [
    "TABLE",
    "Host",
    "Link",
    "NetworkBenchUnavailable",
    "check_machine",
    "clear_commands",
    "has_net_admin",
    "hosts",
    "in_namespace",
    "leftover_namespaces",
    "link",
    "link_command",
    "loss_commands",
    "loss_ruleset",
    "rate_command",
    "remove_leftovers",
    "setup_commands",
    "teardown_commands",
]

_LEFTOVER = re.compile(rf"^{NAME_PREFIX}-(\d+)-(robot|control)$")
CAP_NET_ADMIN = 12
STOP_GRACE_S = 15.0  #: a launcher stops its nodes and scores its run: give it time before SIGKILL


class NetworkBenchUnavailable(RuntimeError):
    """The machine cannot host the bench (privilege, a missing tool): one line for the user, exit 2."""


# -- the commands (functional core) ------------------------------------------------


def setup_commands(robot: Host, control: Host) -> list[list[str]]:
    """Create both namespaces and the veth pair straight inside them (it never exists outside), address and raise it."""
    commands = [["ip", "netns", "add", robot.namespace], ["ip", "netns", "add", control.namespace]]
    commands.append(
        ["ip", "link", "add", robot.device, "netns", robot.namespace, "type", "veth"]
        + ["peer", "name", control.device, "netns", control.namespace]
    )
    for host in (robot, control):
        commands += [
            ["ip", "-n", host.namespace, "link", "set", "lo", "up"],
            ["ip", "-n", host.namespace, "addr", "add", f"{host.address}/{PREFIX_LENGTH}", "dev", host.device],
            ["ip", "-n", host.namespace, "link", "set", host.device, "up"],
        ]
    return commands


def teardown_commands(robot: Host, control: Host) -> list[list[str]]:
    """Remove what ``setup_commands`` and the impairments made; each may fail harmlessly (already gone)."""
    commands = []
    for host in (robot, control):
        commands += clear_commands(host)
    commands.append(["ip", "-n", robot.namespace, "link", "del", robot.device])  # both ends go
    commands += [["ip", "netns", "del", robot.namespace], ["ip", "netns", "del", control.namespace]]
    return commands


def leftover_namespaces(listing: str, alive: set[int] | None = None) -> list[str]:
    """The bench's namespaces in ``ip netns list``'s output whose creator is no longer alive."""
    names = []
    for line in listing.splitlines():
        name = line.split(" ", 1)[0].strip()
        match = _LEFTOVER.match(name)
        if not match:
            continue
        pid = int(match.group(1))
        running = pid in alive if alive is not None else Path(f"/proc/{pid}").exists()
        if not running:
            names.append(name)
    return names


def has_net_admin(status_text: str) -> bool:
    """Whether ``/proc/self/status`` grants CAP_NET_ADMIN in the effective set."""
    for line in status_text.splitlines():
        if line.startswith("CapEff:"):
            return bool(int(line.split()[1], 16) >> CAP_NET_ADMIN & 1)
    return False


# -- running them (imperative shell) -----------------------------------------------


def check_machine(*, need_nft: bool = True) -> None:
    """Raise ``NetworkBenchUnavailable`` with one line if the bench cannot run here."""
    if not has_net_admin(Path("/proc/self/status").read_text()):
        raise NetworkBenchUnavailable(
            "needs root (CAP_NET_ADMIN) to create network namespaces and links: run it with sudo"
        )
    for tool in ("ip", "tc"):
        if shutil.which(tool) is None:
            raise NetworkBenchUnavailable(f"`{tool}` (iproute2) is not installed: apt-get install iproute2")
    if need_nft and shutil.which("nft") is None:
        raise NetworkBenchUnavailable("`nft` is not installed (packet loss uses nftables): run `make nftables`")


def remove_leftovers() -> list[str]:
    """Delete namespaces left by a bench that was killed (SIGKILL leaves no time to clean); their names."""
    listing = _run(["ip", "netns", "list"], check=False).stdout
    names = leftover_namespaces(listing)
    for name in names:
        _run(["ip", "netns", "del", name], check=False)
    return names


def _raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


class Link(Impairments):
    """The two hosts and their link, for the length of a ``with`` block.

    Inside it SIGTERM and SIGHUP end the block as Ctrl-C does (``KeyboardInterrupt``),
    so the cleanup runs whatever ends it; on leaving, the processes started with
    ``spawn`` are stopped (SIGINT, then SIGKILL after ``STOP_GRACE_S``), then
    every table, qdisc, link and namespace is removed, with further signals held off.
    """

    def __init__(self) -> None:
        self.robot, self.control = hosts()
        self.processes: list[subprocess.Popen] = []
        self.removed_leftovers: list[str] = []
        self._previous: dict[int, object] = {}
        self._up = True

    # -- lifetime
    def __enter__(self) -> Link:
        for signum in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
            self._previous[signum] = signal.signal(signum, _raise_interrupt)
        try:
            self.removed_leftovers = remove_leftovers()
            for argv in setup_commands(self.robot, self.control):
                _run(argv)
            self.wait_carrier()
        except BaseException:
            self._teardown()
            raise
        return self

    def __exit__(self, *exc_info) -> None:
        self._teardown()

    def _teardown(self) -> None:
        held = {signum: signal.signal(signum, signal.SIG_IGN) for signum in (signal.SIGINT, signal.SIGTERM)}
        try:
            self.stop_processes()
            for argv in teardown_commands(self.robot, self.control):
                _run(argv, check=False)
        finally:
            for signum, previous in self._previous.items():
                signal.signal(signum, previous)
            for signum in held:
                if signum not in self._previous:
                    signal.signal(signum, held[signum])
            self._previous.clear()

    def wait_carrier(self, timeout_s: float = 5.0) -> None:
        """Until both ends have carrier (LOWER_UP). A participant created before that finds no running
        interface: Fast DDS then announces only its loopback addresses (and a host id that is a constant),
        so the other host never reaches it; it never looks again."""
        deadline = time.monotonic() + timeout_s
        while True:
            states = [
                _run(["ip", "-n", h.namespace, "link", "show", h.device]).stdout for h in (self.robot, self.control)
            ]
            if all("LOWER_UP" in state and "NO-CARRIER" not in state for state in states):
                return
            if time.monotonic() > deadline:
                raise RuntimeError(f"the veth pair has no carrier after {timeout_s:g} s")
            time.sleep(0.02)

    # -- processes
    def spawn(self, host: Host, argv: list[str], *, env: dict[str, str] | None = None, log: Path | None = None):
        """Start ``argv`` inside ``host``'s namespace, in a session of its own (a Ctrl-C reaches it
        once, from here), dying with this process; output to ``log`` (or discarded)."""
        out = open(log, "w") if log is not None else subprocess.DEVNULL  # noqa: SIM115 - closed with the process
        try:
            process = subprocess.Popen(
                in_namespace(host, argv),
                env=env,
                stdin=subprocess.DEVNULL,
                stdout=out,
                stderr=subprocess.STDOUT,
                start_new_session=True,
                preexec_fn=die_with_parent,
            )
        finally:
            if log is not None:
                out.close()
        self.processes.append(process)
        return process

    def stop_processes(self, grace_s: float = STOP_GRACE_S) -> None:
        running = [p for p in self.processes if p.poll() is None]
        for process in running:
            with contextlib.suppress(ProcessLookupError):
                process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + grace_s
        for process in running:
            try:
                process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(process.pid, signal.SIGKILL)
                process.wait()
        self.processes = []


@contextlib.contextmanager
def link() -> Iterator[Link]:
    """``with link() as net:`` the two hosts, checked for privilege and tools first."""
    check_machine()
    with Link() as made:
        yield made
