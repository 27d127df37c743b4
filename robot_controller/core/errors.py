"""Exceptions of the core, subclassing built-ins as python-control does."""


class ConfigError(ValueError):
    """A configuration value is missing, of the wrong type or out of range.

    The message names the key and the problem.
    """


class TimingError(ValueError):
    """Rates that do not fit together (e.g. control period not a whole number of physics steps)."""


class RunFailed(RuntimeError):
    """A run of the graph failed; the message names its folder and why, in one line."""
