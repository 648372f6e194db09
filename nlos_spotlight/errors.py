"""The one exception type that reaches users as a one-line message."""


class NlosError(ValueError):
    """Bad input or an impossible request; the CLI prints ``error: <message>`` and exits 2."""
