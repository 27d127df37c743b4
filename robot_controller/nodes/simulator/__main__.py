"""``python -m robot_controller.nodes.simulator``: run the simulator node."""

from robot_controller.nodes.simulator.node import main

raise SystemExit(main())
