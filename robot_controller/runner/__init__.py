"""Runs the graph: plans which processes to start with which parameters,
forks and supervises them, records, and scores what was recorded."""
