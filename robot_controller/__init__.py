"""robot_controller: a complete robot joint control loop on ROS 2, in Python (its layers: docs/design.md §3)."""

import os

# One BLAS thread: the matrices here are small, and the launcher forks the nodes from itself, which wants no helper
# threads about.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

__version__ = "0.1.0"
