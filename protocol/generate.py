#!/usr/bin/env python3
"""Generate the C++ header and the Python module of the wire protocol from messages.toml.

Usage:
    python protocol/generate.py            # (re)write both generated files
    python protocol/generate.py --check    # exit 1 if either is stale

Outputs:
    firmware/lib/core/protocol_messages.h     (namespace proto, no Arduino header, no heap)
    host_sdk/porosense/protocol/_messages.py  (dataclasses with pack/unpack)
    protocol/vectors/frames.json, frames.txt  (golden frames and streams, gen_vectors.py)
    protocol/spec.md                          (only its catalogue section, gen_spec.py)

Standard library only, so that it runs before any dependency is installed.
"""

from __future__ import annotations

import argparse
import re
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CATALOGUE = ROOT / "protocol" / "messages.toml"
CPP_OUT = ROOT / "firmware" / "lib" / "core" / "protocol_messages.h"
PY_OUT = ROOT / "host_sdk" / "porosense" / "protocol" / "_messages.py"
VECTORS_JSON = ROOT / "protocol" / "vectors" / "frames.json"
VECTORS_TXT = ROOT / "protocol" / "vectors" / "frames.txt"
SPEC = ROOT / "protocol" / "spec.md"

sys.path.insert(0, str(Path(__file__).resolve().parent))
import gen_spec  # noqa: E402
import gen_vectors  # noqa: E402

SCALARS = {
    # name: (size, struct code, C type)
    "u8": (1, "B", "uint8_t"),
    "i8": (1, "b", "int8_t"),
    "u16": (2, "H", "uint16_t"),
    "i16": (2, "h", "int16_t"),
    "u32": (4, "I", "uint32_t"),
    "i32": (4, "i", "int32_t"),
    "f32": (4, "f", "float"),
}
_TYPE_RE = re.compile(r"^(u8|i8|u16|i16|u32|i32|f32)(?:\[(\d*)\])?$")


@dataclass
class Field:
    name: str
    base: str
    count: int | None  # None: scalar; 0: variable trailing array; N: fixed array
    max: int
    unit: str
    doc: str

    @property
    def size(self) -> int:
        return SCALARS[self.base][0]

    @property
    def fixed_bytes(self) -> int:
        if self.count is None:
            return self.size
        return self.size * self.count


@dataclass
class Message:
    name: str
    type: int
    dir: str
    doc: str
    reply: str | None
    fields: list[Field]
    deadline_ms: int = 0  # commands: longest time before the reply starts (spec.md, timing)

    @property
    def variable(self) -> Field | None:
        return self.fields[-1] if self.fields and self.fields[-1].count == 0 else None

    @property
    def min_len(self) -> int:
        return sum(f.fixed_bytes for f in self.fields if f.count != 0)

    @property
    def max_len(self) -> int:
        v = self.variable
        return self.min_len + (v.max * v.size if v else 0)


def _resolve_limits(node, configs: dict):
    """Docs name a configuration limit as {config.NAME.max} (or .min, .default), so that a
    limit is written once, in its [[config]] entry, and every doc that quotes it follows."""
    if isinstance(node, str):

        def sub(m):
            if m.group(1) not in configs:
                raise SystemExit(f"messages.toml: {m.group(0)} names no [[config]] entry")
            return str(configs[m.group(1)][m.group(2)])

        return re.sub(r"\{config\.(\w+)\.(min|max|default)\}", sub, node)
    if isinstance(node, list):
        return [_resolve_limits(v, configs) for v in node]
    if isinstance(node, dict):
        return {k: _resolve_limits(v, configs) for k, v in node.items()}
    return node


def load(path: Path = CATALOGUE) -> dict:
    """Parse and validate the catalogue; raise SystemExit with a clear message on error."""
    cat = tomllib.loads(path.read_text())
    cat = _resolve_limits(cat, {c["name"]: c for c in cat.get("config", [])})
    max_payload = cat["protocol"]["max_payload"]
    msgs = []
    seen_types: dict[int, str] = {}
    for m in cat["message"]:
        fields = []
        for i, f in enumerate(m["fields"]):
            match = _TYPE_RE.match(f["type"])
            if not match:
                sys.exit(f"{path}: {m['name']}.{f['name']}: bad type {f['type']!r}")
            base, count = match.group(1), match.group(2)
            if count is None:
                n = None
            elif count == "":
                n = 0
                if i != len(m["fields"]) - 1:
                    sys.exit(f"{path}: {m['name']}.{f['name']}: only the last field may be variable")
                if "max" not in f:
                    sys.exit(f"{path}: {m['name']}.{f['name']}: a variable array needs max")
            else:
                n = int(count)
            fields.append(Field(f["name"], base, n, int(f.get("max", 0)), f.get("unit", ""), f.get("doc", "")))
        deadline = int(m.get("deadline_ms", cat["protocol"]["deadline_ms"] if m["dir"] == "h2d" else 0))
        msg = Message(m["name"], int(m["type"]), m["dir"], m.get("doc", ""), m.get("reply"), fields, deadline)
        if msg.type in seen_types:
            sys.exit(f"{path}: type 0x{msg.type:02X} used by {seen_types[msg.type]} and {msg.name}")
        seen_types[msg.type] = msg.name
        if msg.max_len > max_payload:
            sys.exit(f"{path}: {msg.name}: payload up to {msg.max_len} bytes exceeds {max_payload}")
        msgs.append(msg)
    names = {m.name for m in msgs}
    for m in msgs:
        if m.reply and m.reply not in names:
            sys.exit(f"{path}: {m.name}: reply {m.reply} is not a message")
    cat["messages"] = msgs
    return cat


def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.lower().split("_"))


# ------------------------------------------------------------------------------ C++


def gen_cpp(cat: dict) -> str:
    p = cat["protocol"]
    out = [
        "// GENERATED by protocol/generate.py from protocol/messages.toml. Do not edit.",
        "// The wire messages of the porosense protocol: ids, codes, flags and payload",
        "// codecs. Pure C++ (no Arduino header, no heap); little-endian on the wire.",
        "#pragma once",
        "#include <stdint.h>",
        "#include <string.h>",
        "",
        "// <avr/io.h> defines ADC (the ADC data register) as a macro: keep it away from the",
        "// names below, so that this header may follow <avr/io.h> or Arduino.h.",
        '#pragma push_macro("ADC")',
        "#undef ADC",
        "",
        "namespace proto {",
        "",
        f"constexpr uint8_t kVersionMajor = {p['major']};",
        f"constexpr uint8_t kVersionMinor = {p['minor']};",
        f"constexpr uint8_t kVersionByte = {p['major'] * 16 + p['minor']};",
        f"constexpr uint8_t kMaxPayload = {p['max_payload']};",
        "",
        "namespace msg {",
    ]
    for m in cat["messages"]:
        out.append(f"constexpr uint8_t {m.name} = 0x{m.type:02X};  // {m.doc.split('.')[0]}")
    out += ["}  // namespace msg", "", "namespace result {"]
    for r in cat["result"]:
        out.append(f"constexpr uint8_t {r['name']} = {r['value']};  // {r['doc']}")
    out += ["}  // namespace result", "", "namespace flag {"]
    for f in cat["flag"]:
        out.append(f"constexpr uint16_t {f['name']} = 1u << {f['bit']};  // {f['doc']}")
    out += ["}  // namespace flag", "", "namespace cap {"]
    for f in cat["capability"]:
        out.append(f"constexpr uint16_t {f['name']} = 1u << {f['bit']};  // {f['doc']}")
    out += ["}  // namespace cap", "", "namespace chan {"]
    for f in cat["channel"]:
        out.append(f"constexpr uint8_t {f['name']} = 1u << {f['bit']};")
    out += ["}  // namespace chan", "", "namespace config {"]
    for c in cat["config"]:
        out.append(f"constexpr uint8_t {c['name']} = {c['key']};  // {c['doc']}")
    out += [
        f"constexpr uint8_t kCount = {len(cat['config'])};",
        "struct KeyInfo { int32_t def; int32_t min; int32_t max; };",
        "// A switch instead of a table keeps the limits in flash, not in the Uno's RAM.",
        "inline bool key_info(uint8_t key, KeyInfo* out) {",
        "  switch (key) {",
    ]
    for c in cat["config"]:
        # Field by field: an aggregate copy would come from a constant in .rodata (RAM on AVR).
        out.append(
            f"    case {c['name']}: out->def = {c['default']}L; out->min = {c['min']}L; "
            f"out->max = {c['max']}L; return true;"
        )
    out += [
        "    default: return false;",
        "  }",
        "}",
        "}  // namespace config",
        "",
        "// Little-endian field access, independent of host byte order and alignment.",
        "inline void put_u8(uint8_t* p, uint8_t v) { p[0] = v; }",
        "inline void put_u16(uint8_t* p, uint16_t v) { p[0] = (uint8_t)v; p[1] = (uint8_t)(v >> 8); }",
        "inline void put_u32(uint8_t* p, uint32_t v) { put_u16(p, (uint16_t)v); put_u16(p + 2, (uint16_t)(v >> 16)); }",
        "inline void put_i8(uint8_t* p, int8_t v) { put_u8(p, (uint8_t)v); }",
        "inline void put_i16(uint8_t* p, int16_t v) { put_u16(p, (uint16_t)v); }",
        "inline void put_i32(uint8_t* p, int32_t v) { put_u32(p, (uint32_t)v); }",
        "inline void put_f32(uint8_t* p, float v) { uint32_t u; memcpy(&u, &v, 4); put_u32(p, u); }",
        "inline uint8_t get_u8(const uint8_t* p) { return p[0]; }",
        "inline uint16_t get_u16(const uint8_t* p) { return (uint16_t)(p[0] | ((uint16_t)p[1] << 8)); }",
        "inline uint32_t get_u32(const uint8_t* p) { return get_u16(p) | ((uint32_t)get_u16(p + 2) << 16); }",
        "inline int8_t get_i8(const uint8_t* p) { return (int8_t)p[0]; }",
        "inline int16_t get_i16(const uint8_t* p) { return (int16_t)get_u16(p); }",
        "inline int32_t get_i32(const uint8_t* p) { return (int32_t)get_u32(p); }",
        "inline float get_f32(const uint8_t* p) { uint32_t u = get_u32(p); float v; memcpy(&v, &u, 4); return v; }",
        "",
        "// Payload structs. encode() writes the payload and returns its length;",
        "// decode() returns false when the length does not fit the message.",
        "// On the AVR (no alignment padding, little-endian) a fixed-length payload is the struct's",
        "// bytes in field order; elsewhere each field is written on its own.",
        "#if defined(__AVR__)",
        "#define POROSENSE_WIRE_IS_STRUCT 1",
        "#else",
        "#define POROSENSE_WIRE_IS_STRUCT 0",
        "#endif",
    ]
    for m in cat["messages"]:
        s = _camel(m.name)
        out.append(f"struct {s} {{")
        out.append(f"  static constexpr uint8_t kType = 0x{m.type:02X};")
        out.append(f"  static constexpr uint8_t kMinLen = {m.min_len};")
        out.append(f"  static constexpr uint8_t kMaxLen = {m.max_len};")
        for f in m.fields:
            ct = SCALARS[f.base][2]
            comment = f"  // {f.unit}" if f.unit else ""
            if f.count is None:
                out.append(f"  {ct} {f.name};{comment}")
            elif f.count == 0:
                out.append(f"  {ct} {f.name}[{f.max}];{comment}")
                out.append(f"  uint8_t {f.name}_count;")
            else:
                out.append(f"  {ct} {f.name}[{f.count}];{comment}")
        # A fixed-length payload on a byte-aligned little-endian target (the AVR) is the
        # struct's own bytes: one copy instead of a store per field (flash).
        if not m.variable:
            out.append("#if POROSENSE_WIRE_IS_STRUCT")
            if m.fields:
                out.append("  uint8_t encode(uint8_t* buf) const { memcpy(buf, this, kMinLen); return kMinLen; }")
                out.append("  bool decode(const uint8_t* buf, uint8_t len) {")
                out.append("    if (len != kMinLen) return false;")
                out.append("    memcpy(this, buf, kMinLen);")
                out.append("    return true;")
                out.append("  }")
            else:
                out.append("  uint8_t encode(uint8_t*) const { return 0; }")
                out.append("  bool decode(const uint8_t*, uint8_t len) { return len == 0; }")
            out.append("#else")
        # encode
        out.append("  uint8_t encode(uint8_t* buf) const {")
        out.append("    uint8_t n = 0;")
        if not m.fields:
            out.append("    (void)buf;")
        for f in m.fields:
            put = f"put_{f.base}"
            if f.count is None:
                out.append(f"    {put}(buf + n, {f.name}); n += {f.size};")
            else:
                cnt = f"{f.name}_count" if f.count == 0 else str(f.count)
                out.append(f"    for (uint8_t i = 0; i < {cnt}; ++i) {{ {put}(buf + n, {f.name}[i]); n += {f.size}; }}")
        out.append("    return n;")
        out.append("  }")
        # decode
        out.append("  bool decode(const uint8_t* buf, uint8_t len) {")
        v = m.variable
        if v:
            out.append(f"    if (len < kMinLen || len > kMaxLen || (len - kMinLen) % {v.size} != 0) return false;")
        else:
            out.append("    if (len != kMinLen) return false;")
        if not m.fields:
            out.append("    (void)buf;")
        else:
            out.append("    uint8_t n = 0;")
        for f in m.fields:
            get = f"get_{f.base}"
            if f.count is None:
                out.append(f"    {f.name} = {get}(buf + n); n += {f.size};")
            elif f.count == 0:
                out.append(f"    {f.name}_count = (uint8_t)((len - kMinLen) / {f.size});")
                out.append(
                    f"    for (uint8_t i = 0; i < {f.name}_count; ++i) {{ {f.name}[i] = {get}(buf + n); n += {f.size}; }}"
                )
            else:
                out.append(
                    f"    for (uint8_t i = 0; i < {f.count}; ++i) {{ {f.name}[i] = {get}(buf + n); n += {f.size}; }}"
                )
        out.append("    return true;")
        out.append("  }")
        if not m.variable:
            out.append("#endif")
        out.append("};")
        if not m.variable and m.fields:
            out.append("#if POROSENSE_WIRE_IS_STRUCT")
            out.append(f'static_assert(sizeof({s}) == {s}::kMinLen, "{s}: struct layout differs from the wire");')
            out.append("#endif")
        out.append("")
    out.append("// Expected payload length bounds of a message type; false for an unknown type.")
    out.append("inline bool payload_bounds(uint8_t type, uint8_t* min_len, uint8_t* max_len) {")
    out.append("  switch (type) {")
    for m in cat["messages"]:
        s = _camel(m.name)
        out.append(f"    case {s}::kType: *min_len = {s}::kMinLen; *max_len = {s}::kMaxLen; return true;")
    out.append("    default: return false;")
    out.append("  }")
    out.append("}")
    out.append("")
    out.append("}  // namespace proto")
    out.append("")
    out.append('#pragma pop_macro("ADC")')
    return "\n".join(out) + "\n"


# ------------------------------------------------------------------------------ Python


def gen_py(cat: dict) -> str:
    p = cat["protocol"]
    out = [
        '"""GENERATED by protocol/generate.py from protocol/messages.toml. Do not edit.',
        "",
        "Message ids, result codes, flags, configuration keys and payload classes of the",
        "porosense wire protocol. Every message class has ``pack() -> bytes`` and",
        "``unpack(payload) -> instance`` (raising ``ValueError`` on a length that does not fit).",
        '"""',
        "",
        "from __future__ import annotations",
        "",
        "import enum",
        "import struct",
        "from dataclasses import dataclass, field",
        "from typing import ClassVar",
        "",
        f"VERSION_MAJOR = {p['major']}",
        f"VERSION_MINOR = {p['minor']}",
        f"VERSION_BYTE = {p['major'] * 16 + p['minor']}",
        f"MAX_PAYLOAD = {p['max_payload']}",
        "",
        "",
        "class MsgType(enum.IntEnum):",
        '    """Message type ids."""',
        "",
    ]
    for m in cat["messages"]:
        out.append(f"    {m.name} = 0x{m.type:02X}")
    out += ["", "", "class Result(enum.IntEnum):", '    """Result codes of NAK and ERROR."""', ""]
    for r in cat["result"]:
        out.append(f"    {r['name']} = {r['value']}  # {r['doc']}")
    out += ["", "", "class StatusFlag(enum.IntFlag):", '    """Status flags of SAMPLE and STATUS_REPLY."""', ""]
    for f in cat["flag"]:
        out.append(f"    {f['name']} = 1 << {f['bit']}  # {f['doc']}")
    out += ["", "", "class Capability(enum.IntFlag):", '    """Capability bits of HELLO_REPLY."""', ""]
    for f in cat["capability"]:
        out.append(f"    {f['name']} = 1 << {f['bit']}  # {f['doc']}")
    out += ["", "", "class Channel(enum.IntFlag):", '    """Stream channel mask bits."""', ""]
    for f in cat["channel"]:
        out.append(f"    {f['name']} = 1 << {f['bit']}")
    out += ["", "", "class ConfigKey(enum.IntEnum):", '    """Configuration keys."""', ""]
    for c in cat["config"]:
        out.append(f"    {c['name']} = {c['key']}  # {c['doc']}")
    out += [
        "",
        "",
        "@dataclass(frozen=True)",
        "class ConfigSpec:",
        '    """Default and accepted range of one configuration key."""',
        "",
        "    key: ConfigKey",
        "    default: int",
        "    min: int",
        "    max: int",
        "    doc: str",
        "",
        "",
        "CONFIG_SPECS: dict[ConfigKey, ConfigSpec] = {",
    ]
    for c in cat["config"]:
        out.append(
            f"    ConfigKey.{c['name']}: ConfigSpec(ConfigKey.{c['name']}, {c['default']}, {c['min']}, {c['max']}, {c['doc']!r}),"
        )
    out += ["}", "", ""]
    out += [
        "class Message:",
        '    """Base of every payload class."""',
        "",
        "    TYPE: ClassVar[int]",
        "    DIRECTION: ClassVar[str]",
        "    REPLY: ClassVar[str | None]",
        "    MIN_LEN: ClassVar[int]",
        "    MAX_LEN: ClassVar[int]",
        "    DEADLINE_MS: ClassVar[int]  # commands: time allowed before the reply starts (0: not a command)",
        "",
        "    def pack(self) -> bytes:  # pragma: no cover - overridden",
        "        raise NotImplementedError",
        "",
        "    @classmethod",
        "    def unpack(cls, payload: bytes) -> Message:  # pragma: no cover - overridden",
        "        raise NotImplementedError",
        "",
        "",
    ]
    for m in cat["messages"]:
        cls = _camel(m.name)
        fixed = [f for f in m.fields if f.count != 0]
        fmt = "<" + "".join(
            (SCALARS[f.base][1] if f.count is None else f"{f.count}{SCALARS[f.base][1]}") for f in fixed
        )
        out.append("@dataclass")
        out.append(f"class {cls}(Message):")
        out.append(f'    """{m.doc}"""')
        out.append("")
        out.append(f"    TYPE: ClassVar[int] = 0x{m.type:02X}")
        out.append(f"    DIRECTION: ClassVar[str] = {m.dir!r}")
        out.append(f"    REPLY: ClassVar[str | None] = {m.reply!r}")
        out.append(f"    MIN_LEN: ClassVar[int] = {m.min_len}")
        out.append(f"    MAX_LEN: ClassVar[int] = {m.max_len}")
        out.append(f"    DEADLINE_MS: ClassVar[int] = {m.deadline_ms}")
        out.append(f"    _FMT: ClassVar[struct.Struct] = struct.Struct({fmt!r})")
        for f in m.fields:
            pytype = "float" if f.base == "f32" else "int"
            note = f"  # {f.unit}" if f.unit else ""
            if f.count is None:
                out.append(f"    {f.name}: {pytype} = 0{'.0' if pytype == 'float' else ''}{note}")
            elif f.count == 0:
                if f.base == "u8":
                    out.append(f"    {f.name}: bytes = b''{note}")
                else:
                    out.append(f"    {f.name}: tuple[{pytype}, ...] = (){note}")
            else:
                zero = "0.0" if pytype == "float" else "0"
                out.append(
                    f"    {f.name}: tuple[{pytype}, ...] = field(default_factory=lambda: ({', '.join([zero] * f.count)},)){note}"
                )
        out.append("")
        # pack
        out.append("    def pack(self) -> bytes:")
        args = []
        for f in fixed:
            args.append(f"self.{f.name}" if f.count is None else f"*self.{f.name}")
        v = m.variable
        for f in fixed:
            if f.count:
                out.append(f"        if len(self.{f.name}) != {f.count}:")
                out.append(f"            raise ValueError('{m.name}.{f.name} needs {f.count} values')")
        out.append(f"        head = self._FMT.pack({', '.join(args)})")
        if v:
            out.append(f"        if len(self.{v.name}) > {v.max}:")
            out.append(f"            raise ValueError('{m.name}.{v.name} holds at most {v.max} values')")
            if v.base == "u8":
                out.append(f"        return head + bytes(self.{v.name})")
            else:
                code = SCALARS[v.base][1]
                out.append(f"        return head + struct.pack('<%d{code}' % len(self.{v.name}), *self.{v.name})")
        else:
            out.append("        return head")
        out.append("")
        # unpack
        out.append("    @classmethod")
        out.append(f"    def unpack(cls, payload: bytes) -> {cls}:")
        if v:
            out.append(
                f"        if not (cls.MIN_LEN <= len(payload) <= cls.MAX_LEN) or (len(payload) - cls.MIN_LEN) % {v.size}:"
            )
        else:
            out.append("        if len(payload) != cls.MIN_LEN:")
        out.append(
            f"            raise ValueError(f'{m.name} payload of {{len(payload)}} bytes (expected {m.min_len}"
            + (f"..{m.max_len}" if v else "")
            + ")')"
        )
        if fixed:
            out.append("        vals = cls._FMT.unpack_from(payload, 0)")
        kwargs = []
        idx = 0
        for f in fixed:
            if f.count is None:
                kwargs.append(f"{f.name}=vals[{idx}]")
                idx += 1
            else:
                kwargs.append(f"{f.name}=tuple(vals[{idx}:{idx + f.count}])")
                idx += f.count
        if v:
            if v.base == "u8":
                out.append(f"        tail = bytes(payload[{m.min_len}:])")
            else:
                code = SCALARS[v.base][1]
                out.append(
                    f"        tail = struct.unpack_from('<%d{code}' % ((len(payload) - {m.min_len}) // {v.size}), payload, {m.min_len})"
                )
            kwargs.append(f"{v.name}=tail")
        out.append(f"        return cls({', '.join(kwargs)})")
        out.append("")
        out.append("")
    out.append("MESSAGES: dict[int, type[Message]] = {")
    for m in cat["messages"]:
        out.append(f"    0x{m.type:02X}: {_camel(m.name)},")
    out.append("}")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--check", action="store_true", help="exit 1 when a generated file is stale")
    args = ap.parse_args(argv)
    cat = load()
    vectors = gen_vectors.build(cat)
    outputs = {
        CPP_OUT: gen_cpp(cat),
        PY_OUT: gen_py(cat),
        VECTORS_JSON: gen_vectors.to_json(vectors),
        VECTORS_TXT: gen_vectors.to_text(vectors),
    }
    if SPEC.exists():
        try:
            outputs[SPEC] = gen_spec.splice(SPEC.read_text(), cat)
        except ValueError as exc:
            sys.exit(f"{SPEC.relative_to(ROOT)}: {exc}")
    stale = [p for p, text in outputs.items() if not p.exists() or p.read_text() != text]
    if args.check:
        for p in stale:
            print(f"stale: {p.relative_to(ROOT)} (run: python protocol/generate.py)")
        return 1 if stale else 0
    for p in stale:
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(outputs[p])
        print(f"wrote {p.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
