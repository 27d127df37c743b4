"""The bench's two hosts on one machine: their namespaces, devices and
addresses, and a command run on the machine or inside one of them.
"""

from __future__ import annotations

import os
import subprocess
from dataclasses import dataclass

PREFIX_LENGTH = 24
NAME_PREFIX = "rcnet"


@dataclass(frozen=True)
class Host:
    role: str  #: "robot" or "control"
    namespace: str
    device: str  #: its end of the veth pair
    address: str  #: without the prefix length


def hosts(pid: int | None = None) -> tuple[Host, Host]:
    """The robot host and the control host of the bench run by process ``pid`` (default: this one)."""
    pid = os.getpid() if pid is None else pid
    return (
        Host("robot", f"{NAME_PREFIX}-{pid}-robot", "rc-robot", "10.203.0.1"),
        Host("control", f"{NAME_PREFIX}-{pid}-control", "rc-control", "10.203.0.2"),
    )


def in_namespace(host: Host, argv: list[str]) -> list[str]:
    return ["ip", "netns", "exec", host.namespace, *argv]


def run(argv: list[str], *, stdin: str | None = None, check: bool = True) -> subprocess.CompletedProcess:
    done = subprocess.run(argv, input=stdin, capture_output=True, text=True, timeout=30)
    if check and done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)}: {done.stderr.strip() or f'exit {done.returncode}'}")
    return done
