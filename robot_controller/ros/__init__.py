"""The ROS plumbing beside the nodes: the node skeleton and its parameters, QoS,
gated publishing, process and spin, scheduling, the run's DDS partition."""
