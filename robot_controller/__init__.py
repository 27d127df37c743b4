"""robot_controller: a complete robot joint control loop on ROS 2, in Python.

Layout: ``core`` is the functional core (control laws, models, metrics; no
ROS); ``nodes`` are the thin ROS 2 shells; ``launcher``, ``report`` and
``cli`` run experiments and score their recordings.
"""

__version__ = "0.1.0"
