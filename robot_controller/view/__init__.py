"""The live 3-D view of a run, in a browser (rerun's web viewer, served from this machine).

- ``urdf_arm`` reads the arm's URDF, ``kinematics`` poses it, ``arm`` draws it;
- ``layout``: entity paths, colours and the saved blueprint;
- ``feed``: the loop's samples thinned (``thinning``) to what a browser takes, held per recording
  stream by an ``outlet``; ``cdr`` reads the few numbers the live viewer needs from raw messages;
- ``serve``: the local servers (rerun's gRPC and web viewer, and a redirect on the chosen port);
- ``from_bag``: the same view built from a saved run's bag (``build_view_from_bag``).

The live stream itself is ``robot_controller.nodes.viewer``, an observer process the launcher
starts beside the recorder (``run --view``). The modules are imported by name: rerun is heavy.
"""

__all__: list[str] = []
