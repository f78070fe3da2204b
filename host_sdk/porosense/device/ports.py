"""Serial ports of this computer, with likely Arduino Unos marked by their USB VID:PID."""

from __future__ import annotations

from dataclasses import asdict, dataclass

# USB identities of Uno boards and the USB-serial chips of common clones.
UNO_USB_IDS: dict[tuple[int, int], str] = {
    (0x2341, 0x0043): "Arduino Uno R3",
    (0x2341, 0x0001): "Arduino Uno",
    (0x2A03, 0x0043): "Arduino Uno (arduino.org)",
    (0x1A86, 0x7523): "Uno clone (CH340)",
    (0x0403, 0x6001): "Uno clone (FTDI FT232R)",
}


@dataclass(frozen=True)
class PortInfo:
    """One serial port: its device path, USB identity when known, and whether it looks like an Uno.

    Attributes
    ----------
    device : str
        Device path or name (``/dev/ttyACM0``, ``COM3``).
    description : str
        The operating system's description ("" when none).
    vid, pid : int or None
        USB vendor and product id (None for a port that is not USB).
    serial_number : str or None
        USB serial number, when the adapter reports one.
    board : str or None
        Board name when the VID:PID belongs to an Uno or a common clone, else None.
    """

    device: str
    description: str
    vid: int | None
    pid: int | None
    serial_number: str | None
    board: str | None

    @property
    def likely_uno(self) -> bool:
        return self.board is not None

    def to_dict(self) -> dict:
        """The fields as a plain dict, with ``likely_uno``.

        Returns
        -------
        dict
            JSON-ready.
        """
        return asdict(self) | {"likely_uno": self.likely_uno}

    def __str__(self) -> str:
        usb = f"{self.vid:04X}:{self.pid:04X}" if self.vid is not None else "----:----"
        mark = f"  <- {self.board}" if self.board else ""
        return f"{self.device:<20} {usb}  {self.description}{mark}"


def classify(vid: int | None, pid: int | None) -> str | None:
    """Board name when the USB VID:PID belongs to an Uno or a common clone, else None."""
    if vid is None or pid is None:
        return None
    return UNO_USB_IDS.get((vid, pid))


def list_ports() -> list[PortInfo]:
    """Every serial port pyserial finds, likely Unos first.

    Returns
    -------
    list of PortInfo
        Likely Unos first, then by device name.
    """
    from serial.tools import list_ports as lp

    ports = [
        PortInfo(p.device, p.description or "", p.vid, p.pid, p.serial_number, classify(p.vid, p.pid))
        for p in lp.comports()
    ]
    return sorted(ports, key=lambda p: (not p.likely_uno, p.device))
