"""The live 3-D view of a run, in a browser (rerun's web viewer, served from this machine).

- ``arm``: the arm drawn from its URDF, posed by joint values;
- ``layout``: entity paths, colours and the saved blueprint;
- ``feed``: the loop's samples thinned to what a browser takes, logged as columns;
- ``serve``: the local servers (rerun's gRPC and web viewer, and a redirect on the chosen port);
- ``from_bag``: the same view built from a saved run's bag (``build_view_from_bag``).

The live stream itself is ``robot_controller.nodes.viewer``, an observer
process the launcher starts beside the recorder (``run --view``).
"""

from __future__ import annotations

from pathlib import Path

__all__ = ["build_view_from_bag"]


def build_view_from_bag(run_dir: Path, port: int = 9090, serve: bool = False) -> Path:
    """See :func:`robot_controller.view.from_bag.build_view_from_bag` (imported on use: rerun is heavy)."""
    from robot_controller.view import from_bag

    return from_bag.build_view_from_bag(run_dir, port, serve)
