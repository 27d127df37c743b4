"""The functional core: control laws, models and metrics.

Nothing here imports ``rclpy``. Time (``t``, ``dt``) and randomness (a seeded
``numpy.random.Generator``) are passed in, so the same code runs in the ROS
nodes, in one process, and in the fast in-process loop.
"""
