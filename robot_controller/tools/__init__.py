"""Command-line tools that talk to a running graph, ros2cli's habits without a ROS install."""
