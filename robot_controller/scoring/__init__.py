"""Reads a run's bag back and scores it: metrics.json and the plots."""
