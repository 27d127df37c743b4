"""robot_controller: a complete robot joint control loop on ROS 2, in Python.

Layout: ``core`` is the functional core (control laws, models, metrics; no
ROS); ``nodes`` are the thin ROS 2 shells; ``launcher``, ``report`` and
``cli`` run experiments and score their recordings.
"""

import os

# One BLAS thread: the matrices here are 3×3, and the launcher forks the
# nodes from itself (``forking``), which wants no helper threads about.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"
