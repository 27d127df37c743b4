"""The impairments of the bench's link, acting on both ends (each direction
alike):

- packet loss: an nftables table of the bench's own in each namespace,
  ``numgen random mod 100 < N drop`` on what arrives from the veth (this kernel has no
  ``netem`` qdisc: checked);
- a bandwidth cap: the ``tbf`` qdisc on each end;
- a cut: the robot end set down, then up.

The command builders are plain functions of their arguments; ``Impairments``
(part of ``netns.Link``) runs them, and reads what they did.
"""

from __future__ import annotations

import re
import time

from robot_controller_lab.network.hosts import Host, in_namespace, run

TABLE = "robot_controller_bench"  #: the nftables table the bench creates in each namespace


def loss_ruleset(device: str, percent: int) -> str:
    """An nftables script: the bench's table, dropping ``percent`` % of the packets arriving on ``device`` at
    random. On arrival, not on departure: a packet dropped on its way out fails the sender's ``sendto`` (EPERM),
    which a lost packet on a real link does not."""
    if not 0 <= percent <= 100 or int(percent) != percent:
        raise ValueError(f"packet loss must be a whole percentage 0..100, got {percent}")
    return (
        f"table inet {TABLE} {{\n"
        "  chain loss {\n"
        "    type filter hook input priority 0; policy accept;\n"
        f'    iifname "{device}" numgen random mod 100 < {int(percent)} counter drop\n'
        "  }\n"
        "}\n"
    )


def loss_commands(host: Host, percent: int) -> tuple[list[str], str]:
    """The command and the script (its standard input) that install the loss in ``host``."""
    return in_namespace(host, ["nft", "-f", "-"]), loss_ruleset(host.device, percent)


def rate_command(host: Host, rate_kbit: int, burst_bytes: int, latency_ms: float) -> list[str]:
    """A token bucket on ``host``'s end of the link: ``rate_kbit`` kbit/s, a burst, and a queue of ``latency_ms``."""
    return ["ip", "netns", "exec", host.namespace, "tc", "qdisc", "replace", "dev", host.device, "root", "tbf"] + [
        "rate",
        f"{int(rate_kbit)}kbit",
        "burst",
        str(int(burst_bytes)),
        "latency",
        f"{latency_ms:g}ms",
    ]


def clear_commands(host: Host) -> list[list[str]]:
    """Remove the bench's loss table and any qdisc from ``host``'s end of the link."""
    return [
        in_namespace(host, ["nft", "delete", "table", "inet", TABLE]),
        ["ip", "netns", "exec", host.namespace, "tc", "qdisc", "del", "dev", host.device, "root"],
    ]


def link_command(host: Host, up: bool) -> list[str]:
    return ["ip", "-n", host.namespace, "link", "set", host.device, "up" if up else "down"]


class Impairments:
    """Loss, a bandwidth cap and cuts on the link of a :class:`~robot_controller_lab.network.netns.Link`, and the
    counters that show their effect."""

    def set_loss(self, percent: int) -> None:
        """``percent`` % of the packets lost in each direction (0: none)."""
        for host in (self.robot, self.control):
            run(in_namespace(host, ["nft", "delete", "table", "inet", TABLE]), check=False)
            if percent:
                argv, script = loss_commands(host, percent)
                run(argv, stdin=script)

    def set_rate(self, rate_kbit: int, burst_bytes: int = 4096, latency_ms: float = 50.0) -> None:
        for host in (self.robot, self.control):
            run(rate_command(host, rate_kbit, burst_bytes, latency_ms))

    def clear(self) -> None:
        for host in (self.robot, self.control):
            for argv in clear_commands(host):
                run(argv, check=False)
        self.set_up(True)

    def set_up(self, up: bool) -> None:
        run(link_command(self.robot, up))
        self._up = up
        if up:
            self.wait_carrier()

    def cut(self, seconds: float) -> tuple[float, float]:
        """The link down for ``seconds``; returns when it went down and came back (system time)."""
        self.set_up(False)
        down_at = time.time()
        try:
            time.sleep(seconds)
        finally:
            self.set_up(True)
        return down_at, time.time()

    def dropped(self) -> int:
        """Packets the loss rules have dropped, both ends together (their counters)."""
        total = 0
        for host in (self.robot, self.control):
            done = run(in_namespace(host, ["nft", "list", "table", "inet", TABLE]), check=False)
            total += sum(int(n) for n in re.findall(r"counter packets (\d+)", done.stdout))
        return total

    def counters(self) -> dict[str, int]:
        """Bytes and packets the robot end has sent and received (``/sys/class/net`` inside its namespace)."""
        out = {}
        for name in ("tx_bytes", "rx_bytes", "tx_packets", "rx_packets", "tx_dropped"):
            done = run(in_namespace(self.robot, ["cat", f"/sys/class/net/{self.robot.device}/statistics/{name}"]))
            out[name] = int(done.stdout.strip())
        return out
