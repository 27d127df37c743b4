"""The live 3-D view of a run, in a browser (rerun's web viewer, served from this machine): ``arm`` draws the arm from
its MuJoCo model; ``layout`` the blueprint; ``feed`` thins samples into each recording stream's ``Outlet``; ``serve``
the local servers; ``from_bag`` the view of a saved run. The live stream is ``robot_controller.nodes.viewer``. The
modules are imported by name: rerun is heavy."""

__all__: list[str] = []
