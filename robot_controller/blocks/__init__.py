"""The loop's ROS-free blocks (planner, controller, drive, world, sensor) and the graph spec that wires them."""
