"""``robot-controller network``: the reference scenario split over two network
namespaces, under each condition of ``conditions``; ``network.json`` and
``network.md`` in ``--out``."""

from __future__ import annotations

import sys
from pathlib import Path

from robot_controller.network import netns


def main(out: Path, *, quick: bool = False) -> int:
    """The verb: exit 0 when every run was made, 1 if one failed, 2 if the machine cannot host the bench."""
    try:
        netns.check_machine()
    except netns.NetworkBenchUnavailable as exc:
        print(f"robot-controller network: {exc}", file=sys.stderr)
        return 2
    print("robot-controller network: not built yet", file=sys.stderr)
    return 1
