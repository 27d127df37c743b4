"""The controller's tick: supervision, the reference in force, safe motion, and what one tick outputs."""
