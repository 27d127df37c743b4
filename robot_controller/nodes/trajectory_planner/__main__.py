"""``python -m robot_controller.nodes.trajectory_planner``: run the planner node."""

from robot_controller.nodes.trajectory_planner.node import main

raise SystemExit(main())
