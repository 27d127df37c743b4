"""Robustness campaigns: a spec of varied parameters and each run's draws from the campaign's seed and its id
(``spec``), one run on the in-process loop, on local processes or a Ray cluster (``executors``), the
results kept and resumed (``store``), the whole run and one run replayed through the ROS graph (``campaign``), and
its report (``report``)."""
