"""``python -m robot_controller.nodes.pid_controller``: run the controller node."""

from robot_controller.nodes.pid_controller.node import main

raise SystemExit(main())
