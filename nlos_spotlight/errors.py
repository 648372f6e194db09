"""The one exception type that reaches users as a one-line message."""


class NlosError(ValueError):
    """Bad input or an impossible request; the CLI prints ``error: <message>`` and exits 2.

    The message is kept to one line: line breaks that arrive with user input (a key or file name
    holding a newline) are written as ``\\n``."""

    def __init__(self, message: str = ""):
        super().__init__(str(message).replace("\r", "\\r").replace("\n", "\\n"))
