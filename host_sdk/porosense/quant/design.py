"""Fixed-point design: from a float EstimatorStructure to a ModelBlob.

Choices (all automatic, each recorded in the report):

* Sections: poles and zeros re-paired with scipy's ``zpk2sos(pairing="nearest")``, which
  orders sections by pole radius (poles closest to the unit circle last); pure delays kept.
* Scaling: every signal node (f output, each section output, the branch sum, g output, the
  output) gets a real scale (units per int16 LSB) such that its guaranteed range maps to
  +-30000 LSB. The range is an interval bound: for a linear block the l1 norm of the positive
  and negative parts of the impulse response applied to the input interval; for a table its
  image of the interval. The input interval is the data range (``input_range``), so no node
  can overflow for any input inside it.
* Numerators: 16-bit coefficients with one shift per section unless that moves the
  section's DC gain by more than ``DC_TOLERANCE`` (zeros near z = 1), then 32-bit.
* Denominators: 16-bit residues with a shift each; direct form with integer base weights
  (-a = m + k, |k| <= 1/2) or, for poles near z = 1, the delta form (alpha1 = 2 + a1,
  alpha0 = 1 + a1 + a2 stored separately, so A(1) keeps 15 significant bits). States are
  32-bit (Q13 of the section output) everywhere.
* Tables: the breakpoints inside the node's input interval plus the interval's ends (in place
  of the breakpoints beyond them), so segments inside the range keep their slopes.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy import signal

from porosense.dsp import fold_delay, split_delay
from porosense.errors import ModelError
from porosense.protocol.model_blob import (
    CRC_LEN,
    HEADER_LEN,
    MAX_BLOB_LEN,
    STATE_FRAC,
    BranchQ,
    ModelBlob,
    OutputQ,
    PwlQ,
    SectionQ,
    numerator_limit,
    pwl_len,
)
from porosense.structure import EstimatorStructure, PiecewiseLinear

FULL_SCALE = 30000.0  # LSB a node's guaranteed range maps to (of 32767)
DC_TOLERANCE = 2e-4  # relative DC-gain error above which a numerator goes to 32 bits
DELTA_LIMIT = 0.49  # |alpha1|, |alpha0| below this -> delta form
DEFAULT_INPUT_LSB = 0.01  # structure input units (dR in %) per 0.01 % LSB


# -- sections ----------------------------------------------------------------------------


def regroup(sos: np.ndarray) -> np.ndarray:
    """Re-pair poles and zeros (nearest) and order sections by pole radius; keeps delays."""
    sos = np.atleast_2d(np.asarray(sos, dtype=float))
    zeros: list[complex] = []
    poles: list[complex] = []
    gain, delay = 1.0, 0
    for row in sos:
        b = np.trim_zeros(row[:3], "b")
        if len(b) == 0:
            return sos  # a zero block: nothing to re-pair
        lead, b = split_delay(b)
        delay += lead
        gain *= b[0]
        zeros.extend(np.roots(b) if len(b) > 1 else [])
        a = np.trim_zeros(row[3:], "b")
        poles.extend(np.roots(a) if len(a) > 1 else [])
    zeros = [z for z in zeros if abs(z) > 0]
    poles = [p for p in poles if abs(p) > 0]
    n_pairs = max(1, (max(len(zeros), len(poles)) + 1) // 2)
    z = np.concatenate([zeros, np.zeros(2 * n_pairs - len(zeros))])
    p = np.concatenate([poles, np.zeros(2 * n_pairs - len(poles))])
    new = signal.zpk2sos(z, p, gain, pairing="nearest")
    if len(new) > 1:
        new = new[np.any(new != [1, 0, 0, 1, 0, 0], axis=1)]
        if len(new) == 0:
            new = np.array([[gain, 0, 0, 1, 0, 0]])
    new = fold_delay(new, delay)
    if len(new) > len(sos) or not _same_response(sos, new):
        return sos
    return new


def _same_response(a: np.ndarray, b: np.ndarray) -> bool:
    w = np.linspace(0, np.pi, 64)
    _, ha = signal.sosfreqz(a, w)
    _, hb = signal.sosfreqz(b, w)
    return bool(np.allclose(hb, ha, rtol=1e-6, atol=1e-9 * float(np.max(np.abs(ha)) + 1e-300)))


def _impulse_length(sos: np.ndarray) -> int:
    r = max((np.max(np.abs(np.roots(row[3:]))) if np.any(row[4:] != 0) else 0.0) for row in sos)
    if r >= 1.0:
        raise ModelError("a linear block is unstable (pole on or outside the unit circle)")
    return int(np.clip(math.ceil(50.0 / max(1.0 - r, 1e-6)) + 16 * len(sos), 64, 500_000))


def prefix_intervals(sos: np.ndarray, lo: float, hi: float) -> list[tuple[float, float]]:
    """Guaranteed output interval after each section for inputs in [lo, hi] (l1 bound)."""
    n = _impulse_length(sos)
    h = np.zeros(n)
    h[0] = 1.0
    out = []
    for row in sos:
        h = signal.sosfilt(row[None, :], h)
        pos, neg = float(np.sum(h[h > 0])), float(np.sum(h[h < 0]))
        out.append((pos * lo + neg * hi, pos * hi + neg * lo))
    return out


def pwl_interval(f: PiecewiseLinear, lo: float, hi: float) -> tuple[float, float]:
    pts = [lo, hi] + [x for x in f.x if lo < x < hi]
    vals = f(np.asarray(pts))
    return float(np.min(vals)), float(np.max(vals))


def _quantize_residue(k: float) -> tuple[int, int]:
    """k (|k| < 1/2) as (mantissa int16, shift n in 16..47) with the most bits."""
    if k == 0.0:
        return 0, 16
    n = 16
    while n < 47 and abs(k) * 2.0 ** (n + 1) <= 32767:
        n += 1
    return int(np.clip(round(k * 2.0**n), -32768, 32767)), n


def quantize_section(row: np.ndarray, s_in: float, s_out: float, notes: list[str], name: str) -> SectionQ:
    """One float section (scipy sos row) with input/output scales -> SectionQ."""
    b = np.asarray(row[:3], dtype=float) * (s_in / s_out) * 2.0**STATE_FRAC  # y Q13 per x LSB
    a1, a2 = float(row[4]), float(row[5])
    b16, sb16, err16 = _numerator(b, wide=False)
    if err16 <= DC_TOLERANCE:
        bq, sb, wide = b16, sb16, False
    else:
        bq, sb, wide = _numerator(b, wide=True)[:2] + (True,)
    alpha1, alpha0 = 2.0 + a1, 1.0 + a1 + a2
    if a2 != 0.0 and abs(alpha1) < DELTA_LIMIT and abs(alpha0) < DELTA_LIMIT:
        (k1, n1), (k2, n2) = _quantize_residue(-alpha1), _quantize_residue(-alpha0)
        sec = SectionQ((int(bq[0]), int(bq[1]), int(bq[2])), (k1, k2), sb, (n1, n2), wide, True, (0, 0))
        form = f"delta form (alpha1={alpha1:.3g}, alpha0={alpha0:.3g})"
    else:
        m1, m2 = int(np.clip(round(-a1), -2, 2)), int(np.clip(round(-a2), -1, 1))
        r1, r2 = -a1 - m1, -a2 - m2
        if round(r1 * 65536) > 32767:
            m1, r1 = m1 + 1, r1 - 1
        if round(r2 * 65536) > 32767:
            m2, r2 = m2 + 1, r2 - 1
        (k1, n1), (k2, n2) = _quantize_residue(r1), _quantize_residue(r2)
        sec = SectionQ((int(bq[0]), int(bq[1]), int(bq[2])), (k1, k2), sb, (n1, n2), wide, False, (m1, m2))
        form = f"direct form (m={m1},{m2})"
    qb, qa = sec.real()
    poles = np.roots(qa)
    if np.any(np.abs(poles) >= 1.0):
        raise ModelError(f"{name}: quantized section became unstable (poles {np.round(poles, 6)})")
    dc_note = f"16-bit DC error {err16:.1e}" if math.isfinite(err16) else "16-bit numerator out of range"
    notes.append(
        f"{name}: poles {_fmt_roots(np.roots([1, a1, a2]))}; {form}, residue shifts {n1},{n2}; "
        f"{'32' if wide else '16'}-bit numerator ({dc_note})"
    )
    return sec


def _numerator(b: np.ndarray, wide: bool) -> tuple[list[int], int, float]:
    """Mantissas and shift for numerator values b (Q13 output per input LSB)."""
    lim, extra = (2**31 - 1, 16) if wide else (32767, 0)
    peak = float(np.max(np.abs(b)))
    sb = 31
    if peak > 0:
        sb = int(np.clip(math.floor(math.log2(lim / peak)) - extra, 0, 31))
    while True:
        q = np.round(b * 2.0 ** (sb + extra))
        if (np.all(np.abs(q) <= lim) and np.sum(np.abs(q)) <= numerator_limit(wide, sb)) or sb == 0:
            break
        sb -= 1
    q = np.clip(q, -lim - 1, lim)
    total = numerator_limit(wide, sb)
    if np.sum(np.abs(q)) > total:  # a numerator gain above 2 (int16 per int16): clipped
        q = np.trunc(q * (total / np.sum(np.abs(q))))
    dc, dcq = float(np.sum(b)), float(np.sum(q)) * 2.0 ** -(sb + extra)
    ref = abs(dc) if abs(dc) > 1e-12 * max(peak, 1e-300) else max(peak, 1e-300)
    return [int(v) for v in q], sb, abs(dcq - dc) / ref


def _fmt_roots(r: np.ndarray) -> str:
    return ", ".join(
        f"{abs(x):.4f}" + (f"@{math.degrees(np.angle(x)):.1f}deg" if abs(x.imag) > 1e-12 else "")
        for x in np.atleast_1d(r)
    )


# -- tables ------------------------------------------------------------------------------


def _table_points(f: PiecewiseLinear, s_x: float, x_range) -> np.ndarray:
    """Breakpoints (LSB of the input) for the input interval ``x_range``: the ones inside, and
    the interval's ends in place of the breakpoints beyond them (outside the interval the table
    only extrapolates, so no more points than the float table). Without the ends, a breakpoint
    beyond the range whose value does not fit an int16 would be dropped and the segment inside
    the range would take the wrong slope."""
    x = f.x / s_x
    if x_range is None:
        return x
    lo, hi = math.floor(x_range[0] / s_x), math.ceil(x_range[1] / s_x)
    inside = x[(x > lo) & (x < hi)]
    return np.concatenate([[lo] if np.any(x <= lo) else [], inside, [hi] if np.any(x >= hi) else []])


def quantize_pwl(
    f: PiecewiseLinear, s_x: float, s_y: float, notes: list[str], name: str, x_range: tuple[float, float] | None = None
) -> PwlQ:
    """A float table with input scale s_x and output scale s_y -> PwlQ; ``x_range``: the input
    interval (input units) the node's scaling guarantees."""
    xq = np.clip(np.round(_table_points(f, s_x, x_range)), -32768, 32767).astype(int)
    keep = np.concatenate([[True], np.diff(xq) > 0])
    # Breakpoints whose value does not fit an int16 lie outside the data range: leave them
    # out, so such inputs extrapolate from the last representable point and saturate (flagged).
    fits = np.abs(f(xq * s_x) / s_y) <= 32767
    if np.count_nonzero(keep & fits) >= 2:
        keep &= fits
    xq = xq[keep]
    if len(xq) < 2:
        lo = int(np.clip(xq[0], -32768, 32766))
        xq = np.array([lo, lo + 1])
    slopes_real = f.slopes
    yq, slope, shift = [], [], []
    for xi in xq:
        yq.append(int(np.clip(round(float(f(xi * s_x)) / s_y), -32768, 32767)))
    for k in range(len(xq) - 1):
        mid = 0.5 * (xq[k] + xq[k + 1]) * s_x
        seg = int(np.clip(np.searchsorted(f.x, mid, side="right") - 1, 0, len(f.x) - 2))
        m = slopes_real[seg] * s_x / s_y
        sh = 30
        if m != 0.0:
            sh = int(np.clip(math.floor(math.log2(32767 / abs(m))), 0, 30))
        mq = round(m * 2.0**sh)
        while abs(mq) > 32767 and sh > 0:
            sh -= 1
            mq = round(m * 2.0**sh)
        if abs(mq) > 32767:
            notes.append(f"{name}: segment {k} slope clipped")
            mq = int(np.clip(mq, -32768, 32767))
        slope.append(int(mq))
        shift.append(sh)
    notes.append(f"{name}: {len(xq)} breakpoints, input {s_x:.4g}/LSB, output {s_y:.4g}/LSB")
    return PwlQ(tuple(int(v) for v in xq), tuple(yq), tuple(slope), tuple(shift))


# -- whole structure ---------------------------------------------------------------------

MAX_NUMERATOR_GAIN = 1.99  # sum |b| in int16 output per int16 input the format allows (< 2)


def _chain_scales(sos: np.ndarray, ivs, s_in: float) -> list[float]:
    """Output scale of each section of a cascade (the last one: the smallest allowed)."""
    out = []
    for row, iv in zip(sos, ivs):
        need = float(np.sum(np.abs(row[:3]))) * s_in / MAX_NUMERATOR_GAIN
        s_in = max(_scale(*iv), need)
        out.append(s_in)
    return out


def _f32_up(x: float) -> float:
    """x rounded up to a float32 (the blob stores out_scale as float32)."""
    f = np.float32(x)
    if float(f) < x:
        f = np.nextafter(f, np.float32(np.inf))
    return float(f)


def _scale(lo: float, hi: float) -> float:
    peak = max(abs(lo), abs(hi))
    return peak / FULL_SCALE if peak > 0 else 1.0 / FULL_SCALE


def design_blob(
    structure: EstimatorStructure,
    input_range: list[tuple[float, float]],
    input_lsb: float,
    model_id: int,
    notes: list[str],
) -> tuple[ModelBlob, list[dict]]:
    """Build the blob; returns it and one dict per node (name, interval, scale)."""
    structure.check_limits()
    nodes: list[dict] = []
    outputs = []
    scales = []
    for out in structure.outputs:
        # 1. Intervals of every node, from the input ranges forward.
        plans = []
        sum_lo = sum_hi = 0.0
        worst_branch = 0.0
        for br in out.branches:
            lo, hi = input_range[br.input]
            lo, hi = lo - br.u_offset, hi - br.u_offset
            f_iv = pwl_interval(br.f, lo, hi) if br.f is not None else (lo, hi)
            sos = regroup(br.h1.sos)
            ivs = prefix_intervals(sos, *f_iv)
            sum_lo, sum_hi = sum_lo + ivs[-1][0], sum_hi + ivs[-1][1]
            worst_branch = max(worst_branch, abs(ivs[-1][0]), abs(ivs[-1][1]))
            plans.append((br, (lo, hi), f_iv, sos, ivs))
        v_iv = (sum_lo, sum_hi)
        g_iv = pwl_interval(out.g, *v_iv) if out.g is not None else v_iv
        h2_sos = regroup(out.h2.sos) if out.h2 is not None else None
        h2_ivs = prefix_intervals(h2_sos, *g_iv) if h2_sos is not None else []
        last = h2_ivs[-1] if h2_ivs else g_iv
        out_l1 = (
            max(abs(last[0]), abs(last[1]), abs(last[0] + out.offset), abs(last[1] + out.offset), 1e-12) / FULL_SCALE
        )
        # 2. Scales: the l1 bound, raised where a section's numerator would need a gain above
        #    MAX_NUMERATOR_GAIN (int16 per int16); the last node of the chain is the output's.
        branch_scales = []
        for br, _x_iv, f_iv, sos, ivs in plans:
            s_in = _scale(*f_iv) if br.f is not None else input_lsb
            branch_scales.append(_chain_scales(sos, ivs, s_in))
        s_sum = max(
            [max(worst_branch, abs(sum_lo), abs(sum_hi)) / FULL_SCALE or 1.0 / FULL_SCALE]
            + [sc[-1] for sc in branch_scales]
        )
        if out.g is None and h2_sos is None:
            out_l1 = s_sum = max(out_l1, s_sum)
        s_g = _scale(*g_iv) if out.g is not None else s_sum
        h2_scales = _chain_scales(h2_sos, h2_ivs, s_g) if h2_sos is not None else []
        out_scale = _f32_up(max([out_l1] + h2_scales[-1:]))
        if out.g is None and h2_sos is None:
            s_sum = out_scale
        if h2_sos is None:
            s_g = out_scale
        scales.append(out_scale)
        # 3. Quantize.
        branches = []
        for (br, x_iv, f_iv, sos, ivs), chain in zip(plans, branch_scales):
            tag = f"{out.name}.b{br.input}"
            fq = None
            s_in = input_lsb
            if br.f is not None:
                s_f = _scale(*f_iv)
                fq = quantize_pwl(br.f, input_lsb, s_f, notes, f"{tag}.f", x_iv)
                nodes.append({"node": f"{tag}.f", "interval": f_iv, "scale": s_f})
                s_in = s_f
            secs = []
            for k, (row, iv) in enumerate(zip(sos, ivs)):
                s_out = s_sum if k == len(sos) - 1 else chain[k]
                secs.append(quantize_section(row, s_in, s_out, notes, f"{tag}.h1[{k}]"))
                nodes.append({"node": f"{tag}.h1[{k}]", "interval": iv, "scale": s_out})
                s_in = s_out
            u_off = int(np.clip(round(br.u_offset / input_lsb), -32768, 32767))
            branches.append(BranchQ(br.input, tuple(secs), fq, br.delay, u_off))
        nodes.append({"node": f"{out.name}.sum", "interval": v_iv, "scale": s_sum})
        gq = None
        if out.g is not None:
            gq = quantize_pwl(out.g, s_sum, s_g, notes, f"{out.name}.g", v_iv)
            nodes.append({"node": f"{out.name}.g", "interval": g_iv, "scale": s_g})
        h2 = []
        if h2_sos is not None:
            s_in = s_g
            for k, (row, iv) in enumerate(zip(h2_sos, h2_ivs)):
                s_out = out_scale if k == len(h2_sos) - 1 else h2_scales[k]
                h2.append(quantize_section(row, s_in, s_out, notes, f"{out.name}.h2[{k}]"))
                nodes.append({"node": f"{out.name}.h2[{k}]", "interval": iv, "scale": s_out})
                s_in = s_out
        offset = int(np.clip(round(out.offset / out_scale), -32768, 32767))
        outputs.append(OutputQ(tuple(branches), gq, tuple(h2), offset))
    blob = ModelBlob(len(structure.inputs), tuple(outputs), tuple(scales), model_id & 0xFFFFFFFF)
    return blob, nodes


def blob_size(
    structure: EstimatorStructure,
    *,
    h1_sections: int | None = None,
    h2_sections: int | None = None,
    breakpoints: int | None = None,
    section_bytes: float = 14.0,
    compact: bool | None = None,
) -> int:
    """Bytes of the blob of ``structure`` with its blocks capped at the given orders: with full
    tables when that fits the model area, else with compact tables (:func:`compact_tables`);
    ``compact`` True / False forces one encoding (True: for a share of a larger blob, which the
    quantizer will encode compactly when the whole does not fit with full tables)."""
    sizes = []
    for full_or_compact in (False, True):
        size: float = HEADER_LEN + CRC_LEN
        for out in structure.outputs:
            size += 4
            for br in out.branches:
                ns = br.h1.n_sections if h1_sections is None else min(br.h1.n_sections, h1_sections)
                size += 6 + ns * section_bytes
                if br.f is not None:
                    size += pwl_len(
                        len(br.f.x) if breakpoints is None else min(len(br.f.x), breakpoints), full_or_compact
                    )
            if out.g is not None:
                size += pwl_len(
                    len(out.g.x) if breakpoints is None else min(len(out.g.x), breakpoints), full_or_compact
                )
            if out.h2 is not None:
                ns = out.h2.n_sections if h2_sections is None else min(out.h2.n_sections, h2_sections)
                size += 1 + ns * section_bytes
        sizes.append(int(math.ceil(size)))
    if compact is not None:
        return sizes[int(compact)]
    return sizes[0] if sizes[0] <= MAX_BLOB_LEN else sizes[1]


def compact_tables(blob: ModelBlob) -> ModelBlob:
    """The blob with every table in the compact encoding (x, y only: 27 bytes fewer per
    10-breakpoint table; the board computes each lookup's slope with one division)."""

    def c(t):
        return None if t is None else PwlQ(t.x, t.y, compact=True)

    outs = tuple(
        OutputQ(tuple(dataclasses.replace(b, f=c(b.f)) for b in o.branches), c(o.g), o.h2, o.offset)
        for o in blob.outputs
    )
    return dataclasses.replace(blob, outputs=outs)


def orders_that_fit(
    structure: EstimatorStructure, section_bytes: float = 14.0, limit: int = 4, capacity: int = MAX_BLOB_LEN
) -> list[str]:
    """The largest uniform caps (poles in H1, poles in H2, breakpoints) whose blob fits.

    Parameters
    ----------
    structure : EstimatorStructure
        The model whose blocks are capped.
    section_bytes : float
        Bytes per second-order section assumed (14 for a 16-bit numerator; a blob's own mean
        when known).
    limit : int
        Most alternatives returned.
    capacity : int
        Bytes the blob may have (the EEPROM model area by default).

    Returns
    -------
    list of str
        One phrase per alternative, largest pole budget first, e.g. ``"H1 <= 6 poles, 8
        breakpoints"``; empty when nothing fits.
    """
    has_h2 = any(o.h2 is not None for o in structure.outputs)
    has_pwl = any(o.g is not None or any(b.f is not None for b in o.branches) for o in structure.outputs)
    fits = []
    for s1 in range(5, 0, -1):
        for s2 in range(5, 0, -1) if has_h2 else [None]:
            for bp in (16, 12, 10, 8, 6, 5, 4, 3, 2) if has_pwl else [None]:
                if (
                    blob_size(structure, h1_sections=s1, h2_sections=s2, breakpoints=bp, section_bytes=section_bytes)
                    <= capacity
                ):
                    fits.append((s1, s2 or 0, bp or 0))
    # For each table size, the largest pole budget (balanced between H1 and H2 on ties).
    out: list[tuple[int, int, int]] = []
    for bp in sorted({c[2] for c in fits}, reverse=True):
        best = max((c for c in fits if c[2] == bp), key=lambda c: (c[0] + c[1], -abs(c[0] - c[1])))
        if out and out[-1][:2] == best[:2]:
            continue
        out.append(best)
    text = []
    for s1, s2, bp in out[:limit]:
        parts = [f"H1 <= {2 * s1} poles"]
        if has_h2:
            parts.append(f"H2 <= {2 * s2} poles")
        if has_pwl:
            parts.append(f"{bp} breakpoints")
        text.append(", ".join(parts))
    return text


def check_size(blob: ModelBlob, structure: EstimatorStructure, capacity: int = MAX_BLOB_LEN) -> None:
    """Raise ModelError (how many bytes too large, which orders fit) if the blob is larger than
    ``capacity`` bytes (the EEPROM model area by default)."""
    length = blob.length
    if length <= capacity:
        return
    per_section = np.mean(
        [s.nbytes for o in blob.outputs for b in o.branches for s in b.sections]
        + [s.nbytes for o in blob.outputs for s in o.h2]
    )
    fits = orders_that_fit(structure, float(per_section), capacity=capacity)
    hint = "; ".join(fits) if fits else "none: reduce the number of outputs or inputs"
    where = "EEPROM model region" if capacity == MAX_BLOB_LEN else "model slot"
    raise ModelError(
        f"model blob is {length} bytes, {length - capacity} bytes too large for the "
        f"{capacity}-byte {where}; orders that fit: {hint}"
    )
