"""The flash model store's upload image: one slot's pages as Intel HEX.

The board keeps two model slots of 1,024 bytes (8 pages of 128 B) at the top of the
application flash, 30,208..32,255, below the 512-byte Optiboot (docs/model-store.md). A slot
holds the blob from its first byte, 0xFF fill, and the EEPROM store's 8-byte slot header in its
last bytes, so an upload (avrdude -D writes pages in address order, each erased by Optiboot
first) writes the header's page last: a torn upload leaves a slot without a valid header, which
the board skips at boot for the previous model. The new model goes into the flash slot that is
not running, with the running model's commit counter + 1, so it is the latest at the next boot.
"""

from __future__ import annotations

import io
import struct
from dataclasses import dataclass

from porosense.errors import DeviceError, ModelError
from porosense.protocol import model_layout as L
from porosense.protocol.framing import crc16
from porosense.protocol.model_blob import ModelBlob

#: Slot numbers MODEL_INFO reports: 0, 1 EEPROM; FLASH_SLOT0 + k flash slot k.
FLASH_SLOT0 = L.SLOTS
SLOT_PAGES = L.FLASH_SLOT_SIZE // L.FLASH_PAGE
NO_SLOT = 0xFF


def slot_address(k: int) -> int:
    """Flash byte address of flash slot ``k`` (0 or 1)."""
    if k not in range(L.FLASH_SLOTS):
        raise ValueError(f"flash slot {k} does not exist (0..{L.FLASH_SLOTS - 1})")
    return L.FLASH_BASE + k * L.FLASH_SLOT_SIZE


def slot_header(blob: bytes, seq: int) -> bytes:
    """The 8-byte slot header of ``blob`` with commit counter ``seq`` (as the EEPROM store's)."""
    crc = int.from_bytes(blob[-2:], "little")
    body = struct.pack("<BBHH", L.SLOT_MAGIC, seq & 0xFF, len(blob), crc)
    return body + struct.pack("<H", crc16(body))


def slot_image(blob: bytes, seq: int) -> bytes:
    """The slot's 1,024 bytes: blob, 0xFF fill, slot header in the last 8 bytes."""
    ModelBlob.from_bytes(blob, max_length=L.FLASH_BLOB_MAX)  # refuses a bad or too large blob
    return blob + b"\xff" * (L.FLASH_BLOB_MAX - len(blob)) + slot_header(blob, seq)


@dataclass(frozen=True)
class FlashUpload:
    """What one upload writes: flash slot ``slot`` (0, 1) with commit counter ``seq``."""

    slot: int
    seq: int
    image: bytes  # the slot's bytes, FLASH_SLOT_SIZE long

    @property
    def address(self) -> int:
        """Flash byte address of the slot's first page."""
        return slot_address(self.slot)

    def pages(self) -> list[tuple[int, bytes]]:
        """(flash address, 128 bytes) in upload order (ascending: the header's page last)."""
        return [
            (self.address + i * L.FLASH_PAGE, self.image[i * L.FLASH_PAGE : (i + 1) * L.FLASH_PAGE])
            for i in range(SLOT_PAGES)
        ]

    def to_hex(self) -> str:
        """Intel HEX holding only this slot's pages."""
        from intelhex import IntelHex

        ih = IntelHex()
        ih.frombytes(self.image, offset=self.address)
        out = io.StringIO()
        ih.write_hex_file(out, write_start_addr=False)
        return out.getvalue()

    def to_dict(self) -> dict:
        return {
            "flash_slot": self.slot,
            "seq": self.seq,
            "address": self.address,
            "bytes": len(self.image),
            "pages": SLOT_PAGES,
        }


def require_flash_store(hello) -> None:
    """Refuse an upload into the flash store of a board that does not read it.

    Parameters
    ----------
    hello : HelloInfo
        The board's handshake. Firmware of protocol 2.2 or later sets the FLASH_STORE
        capability when its image ends at or below the store's base (byte 30,208); an image
        that reaches into the store ignores it, and an upload there would overwrite its code.

    Raises
    ------
    DeviceError
        When the capability is absent, naming why and what to do.
    """
    if "FLASH_STORE" in hello.capabilities:
        return
    if (hello.proto_major, hello.proto_minor) < (2, 2):
        raise DeviceError(
            f"the board's firmware {hello.firmware} (protocol {hello.proto_major}.{hello.proto_minor}) does not say "
            "whether its image leaves the flash model store free: upload the packaged firmware first "
            "(porosense firmware upload --port PORT) or use --store eeprom"
        )
    raise DeviceError(
        f"the board's firmware image reaches into the flash model store (from byte {L.FLASH_BASE:,}), so the board "
        "does not use it and an upload would overwrite the firmware: use --store eeprom, or upload a firmware "
        "that fits its budget (porosense firmware upload)"
    )


def plan_upload(blob: bytes, info) -> FlashUpload:
    """The upload of ``blob`` beside the running model described by ``info`` (a ModelInfo):
    the flash slot that is not running, counter = the running one's + 1 (0 without a model)."""
    running = info.slot if info.valid else NO_SLOT
    slot = 1 if running == FLASH_SLOT0 else 0
    seq = (info.seq + 1) & 0xFF if info.valid else 0
    return FlashUpload(slot, seq, slot_image(blob, seq))


def pages_from_hex(text: str) -> list[tuple[int, bytes]]:
    """The 128-byte pages (ascending) an Intel HEX file writes, each filled with 0xFF where the
    file has no data (as Optiboot programs a page it erased)."""
    from intelhex import IntelHex, IntelHexError

    ih = IntelHex()
    try:
        ih.loadhex(io.StringIO(text))
    except IntelHexError as e:
        raise ModelError(f"not an Intel HEX file: {e}") from None
    ih.padding = 0xFF
    starts = sorted({a - a % L.FLASH_PAGE for a in ih.addresses()})
    out = []
    for p in starts:
        if p + L.FLASH_PAGE > L.BOOTLOADER_BASE:
            raise ModelError(f"HEX writes page 0x{p:04X}, inside the bootloader (from 0x{L.BOOTLOADER_BASE:04X})")
        out.append((p, bytes(ih[a] for a in range(p, p + L.FLASH_PAGE))))
    return out


def upload(dev, blob: bytes, program) -> tuple[FlashUpload, object]:
    """Store ``blob`` in the flash store of the board ``dev`` talks to: plan the slot from its
    MODEL_INFO, ``program(pages)`` (SimBoard.program_flash, Emulator.program_flash: an upload
    that resets the board), handshake again. Returns the plan and the board's MODEL_INFO."""
    require_flash_store(dev.info)
    plan = plan_upload(blob, dev.model_info())
    program(plan.pages())
    dev.after_reset()
    return plan, dev.model_info()
