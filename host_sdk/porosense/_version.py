"""The package's version, written once: pyproject.toml reads it (dynamic version), `porosense
--version` prints it. The firmware's version is separate (kFw* in firmware/lib/core/device.h,
reported by HELLO), as is the wire protocol's (protocol/messages.toml)."""

__version__ = "0.2.0"
