"""The model blob: fixed-point coefficients of the estimator, byte for byte as in EEPROM.

Layout (all little-endian; generated constants in model_layout.py from protocol/model_layout.toml;
firmware/lib/core/MODEL_FORMAT.md is the reference)::

    header (32 bytes): magic "PW", format version (2), n_inputs, n_outputs, reserved 0,
                       length u16 (whole blob), model_id u32, out_scale f32[3],
                       ts_us u32 (sample period), input_lsb f32 (dR % per input LSB: 0.01)
    per output:  n_branches u8, flags u8 (1 g, 2 H2), offset i16 (output LSB)
      per branch: input u8, delay u8, u_offset i16 (0.01 %), flags u8 (1 f), n_sections u8,
                  [f table], H1 sections
      [g table], [n_sections u8, H2 sections]
    crc u16: CRC-16/MCRF4XX of every byte before it

    table:   n u8 (2..16), x i16[n], y i16[n], then per segment slope i16, shift u8 (0..30)
    section: flags u8 (1 wide numerator, 2 delta form, bits 2-4 m1+2, bits 5-6 m2+1),
             sb u8 (0..31), n1 u8, n2 u8 (16..47), b0 b1 b2 (i16, or i32 when wide), k1 k2 i16
"""

from __future__ import annotations

import cmath
import struct
from dataclasses import dataclass, field

from porosense.errors import ModelError
from porosense.protocol.framing import crc16
from porosense.protocol.model_layout import (  # noqa: F401  (re-exported: the blob's constants)
    BRANCH_FORMAT,
    BRANCH_HAS_F,
    CRC_LEN,
    FORMAT_VERSION,
    HEADER_FORMAT,
    HEADER_LEN,
    HEADER_OFFSETS,
    INPUT_LSB_PERCENT,
    MAGIC,
    MAX_BLOB_LEN,
    MAX_BRANCHES,
    MAX_BREAKPOINTS,
    MAX_DELAY,
    MAX_INPUTS,
    MAX_OUTPUTS,
    MAX_SECTIONS,
    MAX_TS_US,
    OUT_HAS_G,
    OUT_HAS_H2,
    OUTPUT_FORMAT,
    SEC_DELTA,
    SEC_WIDE,
    SECTION_FIXED_FORMAT,
    TABLE_COMPACT,
)

STATE_FRAC = 13  # section states are Q13 of the section's int16 output
STATE_MAX = (1 << 28) - 1
STATE_MIN = -(1 << 28)
# The float32 the blob stores for the device's input scaling (compared bit for bit).
DEVICE_INPUT_LSB = struct.unpack("<f", struct.pack("<f", INPUT_LSB_PERCENT))[0]


def blob_crc(data: bytes) -> int:
    """The CRC that identifies a blob (its trailer; MODEL_BEGIN.crc, MODEL_INFO.crc): CRC-16/MCRF4XX
    of every byte before the last two. (The CRC of a whole blob, trailer included, is always 0.)"""
    return crc16(bytes(data[:-CRC_LEN]))


def numerator_limit(wide: bool, sb: int) -> int:
    """Largest sum of |b| the firmware accepts: keeps |round(w / 2^sb)| <= 2^29 and w in int32."""
    if wide:
        return 0xFFFF0000 if sb >= 2 else (1 << (30 + sb)) - 65536
    return 65535 if sb >= 2 else 1 << (14 + sb)


def pwl_len(n: int, compact: bool = False) -> int:
    """Bytes of a table with n breakpoints (compact: x and y only)."""
    return 1 + 4 * n + (0 if compact else 3 * (n - 1))


def section_len(wide: bool) -> int:
    """Bytes of one second-order section."""
    return 4 + (12 if wide else 6) + 4


@dataclass(frozen=True)
class PwlQ:
    """Piecewise-linear table in integers: y = y[k] + round((x - x[k]) * slope[k] / 2^shift[k]).

    A compact table (``compact``, no slope or shift stored) interpolates between its integer
    breakpoints instead: y = y[k] + sign * floor((|x - x[k]| |y[k+1] - y[k]| + floor(d / 2)) / d)
    with d = x[k+1] - x[k] and the sign of the product (one division per lookup on the board)."""

    x: tuple[int, ...]
    y: tuple[int, ...]
    slope: tuple[int, ...] = ()
    shift: tuple[int, ...] = ()
    compact: bool = False

    @property
    def nbytes(self) -> int:
        return pwl_len(len(self.x), self.compact)


@dataclass(frozen=True)
class SectionQ:
    """One second-order section in fixed point (direct form I, int32 states in Q13).

    y = round(w / 2^sb) + base + round(p1 * k1 / 2^n1) + round(p2 * k2 / 2^n2), where
    w = sum b_i x_i (16-bit b) or sum floor(b_i x_i / 2^16) (wide, 32-bit b);
    direct form: base = m1 y1 + m2 y2, p = (y1, y2); delta form: base = 2 y1 - y2,
    p = (y1 - y2, y2).
    """

    b: tuple[int, int, int]
    k: tuple[int, int]
    sb: int
    n: tuple[int, int]
    wide: bool = False
    delta: bool = False
    m: tuple[int, int] = (0, 0)

    @property
    def nbytes(self) -> int:
        return section_len(self.wide)

    @property
    def flags(self) -> int:
        return (
            (SEC_WIDE if self.wide else 0)
            | (SEC_DELTA if self.delta else 0)
            | ((self.m[0] + 2) << 2)
            | ((self.m[1] + 1) << 5)
        )

    def stable(self) -> bool:
        """Whether the board accepts this section's denominator: both poles strictly inside
        the unit circle, decided as the firmware decides (est::blob::section_stable, Q28
        integers: margins under 2^-27 count as unstable, except the delta form's A(1), whose
        sign is k2's)."""
        one, slack = 1 << 28, 2

        def q28(k: int, n: int) -> int:  # k 2^-n in Q28, rounded down
            return k << (28 - n) if n <= 28 else k >> (n - 28)

        r1, r2 = q28(self.k[0], self.n[0]), q28(self.k[1], self.n[1])
        if self.delta:
            return self.k[1] < 0 and r2 - r1 > slack
        c1, c2 = self.m[0] * one + r1, self.m[1] * one + r2
        return one - c1 - c2 > slack and one + c1 - c2 > slack and one + c2 > slack

    def pole_radius(self) -> float:
        """The largest pole magnitude of the section's denominator (float)."""
        _, (_, a1, a2) = self.real()
        d = cmath.sqrt(a1 * a1 - 4 * a2)
        return max(abs((-a1 + d) / 2), abs((-a1 - d) / 2))

    def real(self, s_in: float = 1.0, s_out: float = 1.0):
        """The section's float coefficients (b, a) for input/output scales s_in, s_out."""
        scale = 2.0**-self.sb * (2.0**-16 if self.wide else 1.0) / 2.0**STATE_FRAC
        b = [bi * scale * s_out / s_in for bi in self.b]
        k1, k2 = self.k[0] * 2.0 ** -self.n[0], self.k[1] * 2.0 ** -self.n[1]
        if self.delta:
            # y = (2 - alpha1) y1 + (alpha1 - alpha0 - 1) y2 with k1 = -alpha1, k2 = -alpha0
            a1 = -(2 + k1)
            a2 = -(-1 - k1 + k2)
        else:
            a1 = -(self.m[0] + k1)
            a2 = -(self.m[1] + k2)
        return b, [1.0, a1, a2]


@dataclass(frozen=True)
class BranchQ:
    input: int
    sections: tuple[SectionQ, ...]
    f: PwlQ | None = None
    delay: int = 0
    u_offset: int = 0

    @property
    def nbytes(self) -> int:
        return 6 + (self.f.nbytes if self.f else 0) + sum(s.nbytes for s in self.sections)


@dataclass(frozen=True)
class OutputQ:
    branches: tuple[BranchQ, ...]
    g: PwlQ | None = None
    h2: tuple[SectionQ, ...] = ()
    offset: int = 0

    @property
    def nbytes(self) -> int:
        n = 4 + sum(b.nbytes for b in self.branches)
        n += self.g.nbytes if self.g else 0
        n += 1 + sum(s.nbytes for s in self.h2) if self.h2 else 0
        return n


@dataclass(frozen=True)
class ModelBlob:
    """A parsed model blob; ``to_bytes``/``from_bytes`` round-trip exactly.

    Attributes
    ----------
    n_inputs : int
        Model inputs, 1..3.
    outputs : tuple of OutputQ
        Per output, its branches, tables and sections in fixed point.
    out_scale : tuple of float
        Per output, output units per estimate LSB.
    model_id : int
        32-bit tag.
    format_version : int
        Blob format version.
    meta : dict
        Host-side facts (not stored in the blob, not compared).
    ts_us : int
        Sample period the model was identified at, us.
    input_lsb : float
        dR % per input LSB the coefficients assume (0.01).
    """

    n_inputs: int
    outputs: tuple[OutputQ, ...]
    out_scale: tuple[float, ...]
    model_id: int = 0
    format_version: int = FORMAT_VERSION
    meta: dict = field(default_factory=dict, compare=False)
    ts_us: int = 20000  # sample period the model was identified at (us); quantize sets it from the model
    input_lsb: float = DEVICE_INPUT_LSB  # dR % per input LSB the coefficients assume

    @property
    def ts(self) -> float:
        """Sample period in seconds."""
        return self.ts_us * 1e-6

    @property
    def rate_hz(self) -> float:
        """Sample rate in Hz."""
        return 1e6 / self.ts_us

    @property
    def n_outputs(self) -> int:
        return len(self.outputs)

    @property
    def length(self) -> int:
        """Total bytes, header and CRC included."""
        return HEADER_LEN + sum(o.nbytes for o in self.outputs) + CRC_LEN

    @property
    def crc(self) -> int:
        """The blob's CRC (its last two bytes; MODEL_BEGIN.crc)."""
        return blob_crc(self.to_bytes())

    @property
    def n_sections(self) -> int:
        return sum(len(b.sections) for o in self.outputs for b in o.branches) + sum(len(o.h2) for o in self.outputs)

    # -- serialisation --------------------------------------------------------------

    def to_bytes(self) -> bytes:
        """Serialise the blob as the model stores hold it.

        Returns
        -------
        bytes
            Header, records and CRC trailer (:attr:`length` bytes).

        Raises
        ------
        ModelError
            When a field is out of its format's range.
        """
        try:
            body = bytearray()
            for out in self.outputs:
                flags = (OUT_HAS_G if out.g else 0) | (OUT_HAS_H2 if out.h2 else 0)
                body += struct.pack(OUTPUT_FORMAT, len(out.branches), flags, out.offset)
                for br in out.branches:
                    body += struct.pack(
                        BRANCH_FORMAT, br.input, br.delay, br.u_offset, BRANCH_HAS_F if br.f else 0, len(br.sections)
                    )
                    if br.f:
                        body += _pack_pwl(br.f)
                    body += b"".join(_pack_section(s) for s in br.sections)
                if out.g:
                    body += _pack_pwl(out.g)
                if out.h2:
                    body += struct.pack("<B", len(out.h2)) + b"".join(_pack_section(s) for s in out.h2)
            scales = list(self.out_scale) + [0.0] * (3 - len(self.out_scale))
            length = HEADER_LEN + len(body) + CRC_LEN
            if length > 0xFFFF:
                raise ModelError(f"model blob of {length} bytes cannot be addressed")
            if not 1 <= self.ts_us <= MAX_TS_US:
                raise ModelError(f"sample period {self.ts_us} us outside 1..{MAX_TS_US}")
            head = struct.pack(
                HEADER_FORMAT,
                *MAGIC,
                self.format_version,
                self.n_inputs,
                self.n_outputs,
                0,
                length,
                self.model_id & 0xFFFFFFFF,
                *scales,
                int(self.ts_us),
                self.input_lsb,
            )
        except struct.error as exc:
            raise ModelError(f"model blob field out of range: {exc}") from exc
        data = head + bytes(body)
        return data + struct.pack("<H", blob_crc(data + bytes(CRC_LEN)))

    @classmethod
    def from_bytes(cls, data: bytes, max_length: int = MAX_BLOB_LEN) -> ModelBlob:
        """Parse and check a blob exactly as the firmware does.

        Parameters
        ----------
        data : bytes
            The blob as MODEL_BEGIN / MODEL_CHUNK send it, CRC trailer included.
        max_length : int
            Largest accepted length (bytes): the EEPROM area by default, FLASH_BLOB_MAX for the
            flash store, larger only for blobs that stay in RAM.

        Returns
        -------
        ModelBlob
            The parsed model.

        Raises
        ------
        ModelError
            What is wrong with the blob (magic, version, length, CRC, a record out of range).
        """
        data = bytes(data)
        if data[:2] != MAGIC:
            raise ModelError("not a porosense model blob (bad magic)")
        if len(data) >= 3 and data[2] != FORMAT_VERSION:
            raise ModelError(
                f"model blob format version {data[2]}; this software reads {FORMAT_VERSION}"
                + (" (re-quantize the model)" if data[2] < FORMAT_VERSION else "")
            )
        if len(data) < HEADER_LEN + CRC_LEN:
            raise ModelError(f"model blob of {len(data)} bytes is shorter than its header")
        (_, _, version, n_in, n_out, reserved, length, model_id, *scales, ts_us, input_lsb) = struct.unpack_from(
            HEADER_FORMAT, data.ljust(HEADER_LEN, b"\0"), 0
        )
        if version != FORMAT_VERSION:
            raise ModelError(
                f"model blob format version {version}; this software reads {FORMAT_VERSION}"
                + (" (re-quantize the model)" if version < FORMAT_VERSION else "")
            )
        if length != len(data):
            raise ModelError(f"model blob length field {length} but {len(data)} bytes given")
        if length > max_length:
            raise ModelError(
                f"model blob of {length} bytes exceeds the {max_length}-byte EEPROM model region "
                f"by {length - max_length} bytes"
            )
        if not (1 <= n_in <= MAX_INPUTS and 1 <= n_out <= MAX_OUTPUTS) or reserved:
            raise ModelError(f"model blob has {n_in} inputs and {n_out} outputs (1..3 each)")
        if not 1 <= ts_us <= MAX_TS_US:
            raise ModelError(f"model blob: sample period {ts_us} us outside 1..{MAX_TS_US}")
        if input_lsb != DEVICE_INPUT_LSB:
            raise ModelError(
                f"model blob expects inputs of {input_lsb:g} % dR per LSB; the device sends {INPUT_LSB_PERCENT:g} %"
            )
        (stored,) = struct.unpack_from("<H", data, length - CRC_LEN)
        if blob_crc(data) != stored:
            raise ModelError("model blob CRC mismatch")
        r = _Reader(data, HEADER_LEN, length - CRC_LEN)
        outputs = []
        for _ in range(n_out):
            nb, oflags, offset = r.unpack(OUTPUT_FORMAT)
            if not 1 <= nb <= MAX_BRANCHES or oflags & ~(OUT_HAS_G | OUT_HAS_H2):
                raise ModelError("model blob: bad output record")
            branches = []
            for _ in range(nb):
                inp, delay, u_off, bflags, ns = r.unpack(BRANCH_FORMAT)
                if inp >= n_in or delay > MAX_DELAY or bflags & ~BRANCH_HAS_F:
                    raise ModelError("model blob: bad branch record")
                f = _read_pwl(r) if bflags & BRANCH_HAS_F else None
                branches.append(BranchQ(inp, _read_cascade(r, ns), f, delay, u_off))
            g = _read_pwl(r) if oflags & OUT_HAS_G else None
            h2: tuple[SectionQ, ...] = ()
            if oflags & OUT_HAS_H2:
                (ns,) = r.unpack("<B")
                h2 = _read_cascade(r, ns)
            outputs.append(OutputQ(tuple(branches), g, h2, offset))
        if r.pos != r.end:
            raise ModelError(f"model blob: {r.end - r.pos} unexpected bytes after the last record")
        return cls(
            n_in,
            tuple(outputs),
            tuple(float(s) for s in scales[:n_out]),
            model_id,
            version,
            ts_us=ts_us,
            input_lsb=input_lsb,
        )


def _pack_pwl(p: PwlQ) -> bytes:
    n = len(p.x)
    out = struct.pack(f"<B{n}h{n}h", n | (TABLE_COMPACT if p.compact else 0), *p.x, *p.y)
    if p.compact:
        return out
    return out + b"".join(struct.pack("<hB", m, s) for m, s in zip(p.slope, p.shift))


def _pack_section(s: SectionQ) -> bytes:
    bfmt = "<3i" if s.wide else "<3h"
    return struct.pack(SECTION_FIXED_FORMAT, s.flags, s.sb, *s.n) + struct.pack(bfmt, *s.b) + struct.pack("<2h", *s.k)


class _Reader:
    def __init__(self, data: bytes, pos: int, end: int):
        self.data, self.pos, self.end = data, pos, end

    def unpack(self, fmt: str):
        size = struct.calcsize(fmt)
        if self.pos + size > self.end:
            raise ModelError("model blob truncated")
        vals = struct.unpack_from(fmt, self.data, self.pos)
        self.pos += size
        return vals


def _read_pwl(r: _Reader) -> PwlQ:
    (count,) = r.unpack("<B")
    compact, n = bool(count & TABLE_COMPACT), count & ~TABLE_COMPACT & 0xFF
    if not 2 <= n <= MAX_BREAKPOINTS:
        raise ModelError(f"model blob: table with {n} breakpoints (2..{MAX_BREAKPOINTS})")
    xs = r.unpack(f"<{n}h")
    ys = r.unpack(f"<{n}h")
    segs = [] if compact else [r.unpack("<hB") for _ in range(n - 1)]
    if any(b <= a for a, b in zip(xs, xs[1:])) or any(s > 30 for _, s in segs):
        raise ModelError("model blob: table breakpoints not increasing or shift above 30")
    return PwlQ(tuple(xs), tuple(ys), tuple(m for m, _ in segs), tuple(s for _, s in segs), compact)


def _read_cascade(r: _Reader, n: int) -> tuple[SectionQ, ...]:
    if not 1 <= n <= MAX_SECTIONS:
        raise ModelError(f"model blob: cascade of {n} sections (1..{MAX_SECTIONS})")
    out = []
    for _ in range(n):
        flags, sb, n1, n2 = r.unpack(SECTION_FIXED_FORMAT)
        wide, delta = bool(flags & SEC_WIDE), bool(flags & SEC_DELTA)
        m1, m2 = ((flags >> 2) & 7) - 2, ((flags >> 5) & 3) - 1
        b = r.unpack("<3i" if wide else "<3h")
        k = r.unpack("<2h")
        bad = flags & 0x80 or m1 > 2 or m2 > 1 or (delta and (m1 or m2)) or sb > 31
        bad = bad or not (16 <= n1 <= 47 and 16 <= n2 <= 47)
        bad = bad or sum(abs(v) for v in b) > numerator_limit(wide, sb)
        if bad:
            raise ModelError("model blob: section field out of range")
        sec = SectionQ(tuple(b), tuple(k), sb, (n1, n2), wide, delta, (m1, m2))
        if not sec.stable():
            raise ModelError(
                f"model blob: a section has a pole at |z| = {sec.pole_radius():.6g}, on or outside the unit "
                "circle (unstable: the board refuses it)"
            )
        out.append(sec)
    return tuple(out)
