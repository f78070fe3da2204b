"""Error types shared by every layer.

A ``PorosenseError`` is a user-facing problem (bad file, bad parameter, absent device):
the CLI prints its message and exits with its ``exit_code``, without a traceback.
"""


class PorosenseError(Exception):
    """Base class of every error meant for the user; ``exit_code`` is the CLI's exit status."""

    exit_code = 2


class InputError(PorosenseError, ValueError):
    """Malformed file or out-of-range parameter supplied by the user."""


class DeviceError(PorosenseError):
    """The device is absent, silent, incompatible, or refused a command."""

    exit_code = 3


class ModelError(PorosenseError):
    """A model cannot be built, saved, loaded or quantized as asked."""

    exit_code = 4
