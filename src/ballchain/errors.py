"""The error every layer raises for invalid input (a parameter, a checkpoint that does
not fit the run); the command line reports it in one line and exits with status 2."""


class ParameterError(ValueError):
    """An invalid parameter; the message names it."""
