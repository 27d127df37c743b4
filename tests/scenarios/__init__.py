"""Scenarios: the whole loop run as a user runs it (ROS graphs, CLI verbs), apart from the unit tests
that mirror the modules."""
