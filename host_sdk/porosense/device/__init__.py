"""Talk to a porosense board (real Uno, simboard or emulator) over any pyserial URL.

>>> from porosense.device import Device
>>> with Device.open("socket://127.0.0.1:5000") as dev:   # doctest: +SKIP
...     print(dev.hello())
"""

from porosense.device.client import ALL_CHANNELS, Device, NakError, blob_crc
from porosense.device.control import ControlGains
from porosense.device.ports import PortInfo, list_ports
from porosense.device.results import (
    DeviceStatus,
    HelloInfo,
    LinkStats,
    ModelInfo,
    PingResult,
    Sample,
    SampleBlock,
)

__all__ = [
    "ALL_CHANNELS",
    "ControlGains",
    "Device",
    "NakError",
    "blob_crc",
    "PortInfo",
    "list_ports",
    "DeviceStatus",
    "HelloInfo",
    "LinkStats",
    "ModelInfo",
    "PingResult",
    "Sample",
    "SampleBlock",
]
