"""Non-volatile state of the emulated board: the model store and the configuration store.

The model store follows the firmware's rules: MODEL_BEGIN first invalidates the stored model,
chunks must arrive contiguously from offset 0, MODEL_COMMIT checks length, CRC and structure
before it marks the model valid. A power loss in the middle of a write therefore leaves no
model, never a broken one. ``power_fail_after`` simulates that loss after a number of bytes.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field

from porosense.protocol import Result
from porosense.protocol._messages import CONFIG_SPECS

MODEL_REGION_BYTES = 1024 - 64  # EEPROM 64..1023 (interfaces: header + blob)
MIN_BLOB_BYTES = 24 + 2  # a blob's header and CRC


def blob_crc(blob: bytes) -> int:
    """CRC identifying a blob: the CRC-16/MCRF4XX of the bytes before its trailing CRC."""
    from porosense.protocol import crc16

    return crc16(blob[:-2]) if len(blob) >= 2 else crc16(blob)


class PowerLoss(Exception):
    """Raised inside a write when the injected power loss strikes."""


@dataclass
class ModelHeader:
    valid: bool = False
    length: int = 0
    crc: int = 0
    format_version: int = 0


@dataclass
class ModelStore:
    """The model region of the EEPROM and the write in progress (RAM).

    ``capacity`` is the largest blob (bytes); ``parse(blob)`` returns a loaded model or
    raises on a blob the estimator refuses; ``format_version`` (None: any) is what BEGIN needs.
    """

    capacity: int
    parse: object
    format_version: int | None = None
    header: ModelHeader = field(default_factory=ModelHeader)
    data: bytearray = field(default_factory=bytearray)
    power_fail_after: int | None = None  # bytes still writable before the power fails
    bytes_written: int = 0
    _writing: ModelHeader | None = None
    _offset: int = 0

    def __post_init__(self):
        if not self.data:
            self.data = bytearray(self.capacity)

    # Every EEPROM byte write goes through here so that a power loss can strike mid-chunk.
    def _write(self, offset: int, payload: bytes) -> None:
        for i, b in enumerate(payload):
            if self.power_fail_after is not None:
                if self.power_fail_after <= 0:
                    self.power_fail_after = None
                    raise PowerLoss(f"power lost after {self.bytes_written} model bytes")
                self.power_fail_after -= 1
            self.data[offset + i] = b
            self.bytes_written += 1

    def reboot(self) -> None:
        """RAM state is lost at a reset: any write in progress is forgotten."""
        self._writing = None
        self._offset = 0

    def stored_blob(self) -> bytes | None:
        """The blob of a valid header, else None."""
        if not self.header.valid:
            return None
        return bytes(self.data[: self.header.length])

    def begin(self, length: int, crc: int, format_version: int) -> tuple[int, int]:
        if length > self.capacity:
            return Result.TOO_LARGE, min(length - self.capacity, 32767)
        wrong_format = self.format_version is not None and format_version != self.format_version
        if wrong_format or length < MIN_BLOB_BYTES:
            return Result.BAD_MODEL, 0
        self.header = ModelHeader()  # invalidated before the first byte changes
        self._writing = ModelHeader(False, length, crc, format_version)
        self._offset = 0
        return Result.OK, 0

    def chunk(self, offset: int, payload: bytes) -> tuple[int, int]:
        if self._writing is None:
            return Result.BAD_STATE, 0
        if offset != self._offset:
            return Result.BAD_STATE, self._offset
        excess = offset + len(payload) - self._writing.length
        if excess > 0:
            return Result.TOO_LARGE, excess
        self._write(offset, payload)
        self._offset += len(payload)
        return Result.OK, 0

    def commit(self) -> tuple[int, int, object]:
        """(code, detail, parsed model or None)."""
        w = self._writing
        if w is None:
            return Result.BAD_STATE, 0, None
        if self._offset != w.length:
            return Result.BAD_STATE, self._offset, None
        blob = bytes(self.data[: w.length])
        self._writing = None
        if blob_crc(blob) != w.crc or int.from_bytes(blob[-2:], "little") != w.crc:
            return Result.BAD_MODEL, 0, None
        try:
            model = self.parse(blob)
        except Exception:
            return Result.BAD_MODEL, 1, None
        self.header = ModelHeader(True, w.length, w.crc, w.format_version)
        return Result.OK, 0, model

    def erase(self) -> None:
        self.header = ModelHeader()
        self._writing = None

    def read(self, offset: int, n: int) -> tuple[int, bytes]:
        if not self.header.valid:
            return Result.NO_MODEL, b""
        if offset + n > self.header.length:
            return Result.OUT_OF_RANGE, b""
        return Result.OK, bytes(self.data[offset : offset + n])


def default_config() -> dict[int, int]:
    """The documented defaults of every configuration key."""
    return {int(k): s.default for k, s in CONFIG_SPECS.items()}


def check_config(key: int, value: int) -> int:
    """Result code of setting ``key`` to ``value`` (BAD_KEY, OUT_OF_RANGE or OK)."""
    spec = next((s for k, s in CONFIG_SPECS.items() if int(k) == key), None)
    if spec is None:
        return Result.BAD_KEY
    if not spec.min <= value <= spec.max:
        return Result.OUT_OF_RANGE
    return Result.OK


@dataclass
class ConfigStore:
    """The stored configuration (two-slot and atomic on the board: a save is all or nothing)."""

    saved: dict[int, int] | None = None  # None: never written or corrupt
    boots: int = 0

    def load(self) -> dict[int, int] | None:
        return copy.deepcopy(self.saved)

    def save(self, config: dict[int, int]) -> None:
        self.saved = dict(config)
