"""Experiments built on runs: step, compare, faults, tune, identify, campaigns, the tutorial's exercises, and the
in-process loop they share."""
