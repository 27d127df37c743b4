"""Experiments and benches built on runs: step, compare, bench, faults, floods,
the in-process loop."""
