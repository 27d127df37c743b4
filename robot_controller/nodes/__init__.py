"""ROS 2 shells around the core: parameters in, messages to arrays, call the
core, arrays to messages. One node per module, each with ``main()``."""
