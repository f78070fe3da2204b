"""The catalogue tables of protocol/spec.md, rendered from messages.toml.

spec.md is written by hand except the part between BEGIN and END below, which
protocol/generate.py replaces so that the tables never disagree with the catalogue.
"""

from __future__ import annotations

BEGIN = "<!-- BEGIN GENERATED CATALOGUE (protocol/generate.py; edit messages.toml instead) -->"
END = "<!-- END GENERATED CATALOGUE -->"
SIZES = {"u8": 1, "i8": 1, "u16": 2, "i16": 2, "u32": 4, "i32": 4, "f32": 4}


def _esc(text: str) -> str:
    return text.replace("|", "\\|")


def _length(m, extra: int = 0) -> str:
    lo, hi = m.min_len + extra, m.max_len + extra
    return str(lo) if lo == hi else f"{lo}..{hi}"


# Header, CRC, one COBS overhead byte and the delimiter around every payload.
FRAME_OVERHEAD = 4 + 2 + 1 + 1


def render(cat: dict) -> str:
    """Markdown tables of messages, fields, result codes, flags, capabilities, keys."""
    msgs = cat["messages"]
    replies_to = {}
    for m in msgs:
        if m.reply:
            replies_to.setdefault(m.reply, []).append(m.name)
    out = [
        BEGIN,
        "",
        "### Message summary",
        "",
        "| type | name | direction | answered by | reply deadline | payload bytes | bytes on the wire |",
        "|---|---|---|---|---|---|---|",
    ]
    for m in sorted(msgs, key=lambda m: m.type):
        if m.dir == "h2d":
            answer = m.reply or "-"
        elif m.name == "NAK":
            answer = "(answers any command it refuses)"
        elif m.name in replies_to:
            answer = "(answers " + ", ".join(replies_to[m.name]) + ")"
        else:
            answer = "(unsolicited)"
        deadline = f"{m.deadline_ms} ms" if m.deadline_ms else "-"
        out.append(
            f"| 0x{m.type:02X} | {m.name} | {'host -> device' if m.dir == 'h2d' else 'device -> host'} | {answer} "
            f"| {deadline} | {_length(m)} | {_length(m, FRAME_OVERHEAD)} |"
        )
    out += ["", "### Messages", ""]
    for m in msgs:
        out.append(
            f"#### {m.name} (0x{m.type:02X}, {'host -> device' if m.dir == 'h2d' else 'device -> host'}, {_length(m)} bytes)"
        )
        out.append("")
        out.append(_esc(m.doc) + (f" Answered by {m.reply}." if m.reply else ""))
        out.append("")
        if not m.fields:
            out += ["Empty payload.", ""]
            continue
        out += ["| offset | field | type | unit | meaning |", "|---|---|---|---|---|"]
        offset = 0
        for f in m.fields:
            if f.count is None:
                t = f.base
            elif f.count == 0:
                t = f"{f.base}[0..{f.max}]"
            else:
                t = f"{f.base}[{f.count}]"
            out.append(f"| {offset} | {f.name} | {t} | {_esc(f.unit) or '-'} | {_esc(f.doc) or '-'} |")
            if f.count != 0:
                offset += SIZES[f.base] * (f.count or 1)
        out.append("")
    out += ["### Result codes (NAK.code, ERROR.code)", "", "| value | name | meaning |", "|---|---|---|"]
    for r in cat["result"]:
        out.append(f"| {r['value']} | {r['name']} | {_esc(r['doc'])} |")
    out += ["", "### Status flags (SAMPLE.status, STATUS_REPLY.flags)", "", "| bit | name | meaning |", "|---|---|---|"]
    for f in cat["flag"]:
        out.append(f"| {f['bit']} | {f['name']} | {_esc(f['doc'])} |")
    out += ["", "### Capabilities (HELLO_REPLY.capabilities)", "", "| bit | name | meaning |", "|---|---|---|"]
    for f in cat["capability"]:
        out.append(f"| {f['bit']} | {f['name']} | {_esc(f['doc'])} |")
    out += [
        "",
        "### Stream channels (START_STREAM.channel_mask, SAMPLE.channel_mask)",
        "",
        "| bit | name |",
        "|---|---|",
    ]
    for f in cat["channel"]:
        out.append(f"| {f['bit']} | {f['name']} |")
    out += [
        "",
        "### Configuration keys (CONFIG_GET / CONFIG_SET, values i32)",
        "",
        "| key | name | default | min | max | meaning |",
        "|---|---|---|---|---|---|",
    ]
    for c in cat["config"]:
        out.append(f"| {c['key']} | {c['name']} | {c['default']} | {c['min']} | {c['max']} | {_esc(c['doc'])} |")
    out += ["", END]
    return "\n".join(out)


def splice(spec_text: str, cat: dict) -> str:
    """spec_text with its generated section replaced; ValueError when the markers are missing."""
    start = spec_text.find(BEGIN)
    stop = spec_text.find(END)
    if start < 0 or stop < start:
        raise ValueError(f"spec.md lacks the markers {BEGIN!r} ... {END!r}")
    return spec_text[:start] + render(cat) + spec_text[stop + len(END) :]
