"""Exceptions raised by flagellum.

Every user-facing error derives from :class:`FlagellumError`; the CLI turns it into a
one-line message on stderr and exit code 2.
"""


class FlagellumError(Exception):
    """Base class of all errors that the CLI reports as one line, exit code 2."""


class ParameterError(FlagellumError, ValueError):
    """An invalid parameter value: names the parameter, its value and the allowed range."""

    def __init__(self, name: str, value, allowed: str):
        self.name, self.value, self.allowed = name, value, allowed
        super().__init__(f"invalid {name} = {value!r}: must be {allowed}")

    def __reduce__(self):  # raised in a worker process: pickled back to the parent
        return type(self), (self.name, self.value, self.allowed)


class SimulationError(FlagellumError, RuntimeError):
    """A run that could not continue (blow-up, step failure); the last good state is kept."""
