"""Protocol version rules: the major must match, a different minor is compatible.

The version byte of every header is major * 16 + minor. A device answers HELLO whatever
version byte the HELLO carried, and the host decoder accepts HELLO_REPLY from any version,
so that the host can name the mismatch instead of timing out.
"""

from __future__ import annotations

from porosense.errors import DeviceError
from porosense.protocol._messages import VERSION_MAJOR, VERSION_MINOR


class ProtocolVersionError(DeviceError):
    """The device speaks a protocol major version other than the host's (a DeviceError: exit 3)."""


def split_version(version_byte: int) -> tuple[int, int]:
    """Protocol major and minor of a header version byte.

    Parameters
    ----------
    version_byte : int
        Header version byte, major * 16 + minor.

    Returns
    -------
    major, minor : int
        Each 0..15.
    """
    return (version_byte >> 4) & 0x0F, version_byte & 0x0F


def check_compatible(proto_major: int, proto_minor: int) -> None:
    """Raise ProtocolVersionError unless a device at proto_major.proto_minor can be used.

    A minor release only adds (message types, result codes, flags, configuration keys) and
    never changes an existing layout, so any minor is compatible; a different major is not.

    Parameters
    ----------
    proto_major, proto_minor : int
        The device's protocol version (from HELLO_REPLY).

    Raises
    ------
    ProtocolVersionError
        A major other than this host's; the message says which side to update.
    """
    if proto_major != VERSION_MAJOR:
        raise ProtocolVersionError(
            f"device speaks protocol {proto_major}.{proto_minor}, this host speaks "
            f"{VERSION_MAJOR}.{VERSION_MINOR}: update the "
            + (
                "host software (pip install -U porosense)"
                if proto_major > VERSION_MAJOR
                else "firmware (make -C firmware upload)"
            )
        )


def hello_versions(payload: bytes) -> tuple[int, int]:
    """(proto_major, proto_minor) of a HELLO_REPLY payload of any major.

    Every major keeps these two bytes first, so they can be read before knowing the rest
    of the layout.

    Parameters
    ----------
    payload : bytes
        A HELLO_REPLY payload.

    Returns
    -------
    proto_major, proto_minor : int
        The device's protocol version.

    Raises
    ------
    ProtocolVersionError
        A payload shorter than 2 bytes.
    """
    if len(payload) < 2:
        raise ProtocolVersionError(f"HELLO_REPLY of {len(payload)} bytes carries no protocol version")
    return payload[0], payload[1]
