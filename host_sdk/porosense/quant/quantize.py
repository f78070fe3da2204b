"""``quantize``: float EstimatorStructure -> fixed-point blob + report."""

from __future__ import annotations

import dataclasses
import zlib
from dataclasses import dataclass

import numpy as np

from porosense.errors import InputError, ModelError
from porosense.protocol.model_blob import MAX_BLOB_LEN, ModelBlob
from porosense.quant import checks
from porosense.quant.design import DEFAULT_INPUT_LSB, FULL_SCALE, check_size, compact_tables, design_blob
from porosense.quant.fixed import FixedPointEstimator
from porosense.quant.report import QuantReport, RecordingFit, fit_percent
from porosense.structure import EstimatorStructure

DEFAULT_INPUT_RANGE = (-100.0, 100.0)  # dR in %, only for a structure that carries no input peak
# The noise probe: white noise of this RMS (device LSB, 0.01 % of dR) on the device inputs. The
# board's dR readings carry a few LSB of noise (ADS1115 and contact noise), so a model whose fit
# drops by points at 1 LSB is unusable on the device even when its fixed-point loss is nil.
NOISE_PROBE_LSB = 1.0
NOISE_PROBE_SEED = 7


@dataclass
class QuantResult:
    """What ``quantize`` made.

    Attributes
    ----------
    blob : ModelBlob
        The fixed-point model (``to_bytes()``: what MODEL_BEGIN/CHUNK send).
    report : QuantReport
        Formats chosen, sizes and the fits of the fixed-point reference.
    """

    blob: ModelBlob
    report: QuantReport

    def to_bytes(self) -> bytes:
        """The blob as the model stores hold it.

        Returns
        -------
        bytes
            What MODEL_BEGIN and MODEL_CHUNK send.
        """
        return self.blob.to_bytes()


# A model whose inputs were declared in % (or not at all) but never exceeded this magnitude in
# identification was almost surely fitted on dR / 100: the actuators' dR spans tens of %.
FRACTION_SUSPECT_PEAK = 1.5


def quantize(
    structure: EstimatorStructure,
    *,
    recordings=None,
    input_range=None,
    model_id: int | None = None,
    noise_lsb: float | None = None,
    capacity: int = MAX_BLOB_LEN,
    force: bool = False,
) -> QuantResult:
    """Quantize ``structure`` for the firmware.

    The input scaling comes from the structure alone (``structure.input_units``: dR in % or
    dR/100; the device sends 0.01 % steps) and the sample period from ``structure.ts``; both
    are stored in the blob. The report's fits are what the device computes: the bit-exact
    fixed-point estimator on the recordings' inputs converted exactly as the device converts
    them (:func:`evaluate`).

    Parameters
    ----------
    structure : EstimatorStructure
        The float model.
    recordings : sequence or None
        Recordings (porosense.data.Recording or mappings name -> column) holding the
        structure's input columns (and its output columns for the fit against data), or
        (name, U (N, n_in), Y (N, n_out) or None) tuples, in structure units. They set the
        data range when ``input_range`` is absent and are replayed for the report.
    input_range : (lo, hi) or sequence of (lo, hi) or None
        Input range in the structure's input unit (% dR or dR/100), one pair or one per input;
        the scaling guarantees no overflow for inputs inside it. Default: the recordings' range
        widened by 25 % of its span; without recordings the model's own range (+- 1.5 times its
        identification peak, ``structure.input_peak``; -100..100 % only for a structure that
        carries no peak).
    model_id : int or None
        32-bit tag stored in the blob (default: CRC-32 of the blob with model_id 0, so the same
        coefficients, sample period and scaling always give the same blob).
    noise_lsb : float or None
        RMS of the white noise of the report's noise probe, device input LSB (0.01 % dR)
        (default NOISE_PROBE_LSB = 1; 0 skips it).
    capacity : int
        Bytes the blob may have (default the EEPROM model area, MAX_BLOB_LEN;
        ``FLASH_BLOB_MAX`` for a flash store slot). Compact tables are used only when the full
        encoding does not fit it.
    force : bool
        Turn the checks of porosense.quant.checks (non-finite coefficients, breakpoints that do
        not increase, poles on or outside the unit circle, a fixed-point estimate that saturates
        or misses the float model on the recordings, or without recordings on a probe of steps
        across the input range) into warnings in the report's notes instead of a ModelError.

    Returns
    -------
    QuantResult
        The blob and its report.

    Raises
    ------
    ModelError
        A check that fails (unless ``force``), a blob larger than ``capacity`` (naming the orders
        that fit), or undeclared input units with an identification peak under 1.5 (almost
        surely a model fitted on dR/100).
    InputError
        A recording without the model's input columns, or an input range with lo >= hi.
    """
    noise_lsb = NOISE_PROBE_LSB if noise_lsb is None else float(noise_lsb)
    forced: list[str] = []

    def check(fn, *args) -> None:
        try:
            fn(*args)
        except ModelError as exc:
            if not force:
                raise
            forced.append(f"forced past a refusal: {exc}")

    check(checks.check_structure, structure)
    _check_units(structure)
    lsb = structure.input_lsb()
    ts_us = _ts_us(structure.ts)
    check(_check_rate, structure.ts)
    recs = [_as_recording(r, structure, i) for i, r in enumerate(recordings or [])]
    ranges = _input_ranges(structure, recs, input_range, lsb)
    notes: list[str] = []
    blob, nodes = design_blob(structure, ranges, lsb, 0, notes)
    blob = dataclasses.replace(blob, ts_us=ts_us)
    if blob.length > capacity:  # too large with full tables: try compact ones
        small = compact_tables(blob)
        if small.length < blob.length:
            notes.append(
                f"compact tables: {blob.length} bytes with full tables, {small.length} compact (the board "
                "computes each lookup's slope from the two breakpoints, one division)"
            )
            blob = small
    mid = model_id if model_id is not None else zlib.crc32(blob.to_bytes()) & 0xFFFFFFFF
    blob = dataclasses.replace(blob, model_id=mid & 0xFFFFFFFF)
    check_size(blob, structure, capacity)
    secs = [s for o in blob.outputs for b in o.branches for s in b.sections] + [s for o in blob.outputs for s in o.h2]
    scaling = (
        "l1 interval bound: each node's range is the input interval through the positive and "
        "negative parts of the impulse response (tables: their image), mapped to "
        f"+-{FULL_SCALE:.0f} LSB; input ranges " + ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in ranges)
    )
    notes[:0] = forced
    report = QuantReport(
        blob_bytes=blob.length,
        capacity_bytes=capacity,
        n_sections=len(secs),
        wide_numerators=sum(s.wide for s in secs),
        delta_sections=sum(s.delta for s in secs),
        out_scale=list(blob.out_scale),
        scaling=scaling,
        nodes=nodes,
        notes=notes,
    )
    guessed = [name for name, u, _ in recs if off_grid(u, lsb)]
    if guessed:
        notes.append(
            f"inputs not on the device's {lsb:g}-unit grid in {', '.join(guessed)}: not what a device "
            "measured (noise-free truth or a simulation?); the fits use them rounded as the device "
            "rounds, and the noise probe shows what sensor noise would cost"
        )
    for name, u, y in recs:
        report.fits.extend(evaluate(structure, blob, u, y, name, lsb, noise_lsb))
    if not recs:  # no data: the fixed-point arithmetic is still checked across the input range
        probe = checks.probe_inputs(ranges)
        report.fits.extend(evaluate(structure, blob, probe, None, "probe (steps across the input range)", lsb, 0.0))
    check(checks.check_fits, report)
    notes.extend(n for n in forced if n not in notes)
    return QuantResult(blob, report)


def _ts_us(ts: float) -> int:
    """The sample period in whole microseconds, as the blob stores it."""
    if not np.isfinite(ts) or ts <= 0:
        raise ModelError(f"the model's sample period {ts} s is not a positive number")
    us = int(round(ts * 1e6))
    if not 1 <= us <= 65_535_000 or abs(us - ts * 1e6) > 1e-6 * ts * 1e6 + 0.5:
        raise ModelError(f"the model's sample period {ts} s cannot be stored (1 us .. 65.5 s)")
    return us


def _check_rate(ts: float) -> None:
    """Refuse a model at a rate the board cannot sample at (SAMPLE_RATE_HZ, 10..135 Hz): a blob
    at 0.05 Hz is a model identified on a time column in ms read as seconds, or a --ts in ms."""
    from porosense.protocol._messages import CONFIG_SPECS, ConfigKey

    spec = CONFIG_SPECS[ConfigKey.SAMPLE_RATE_HZ]
    rate = 1.0 / ts
    if not spec.min * (1 - 1e-6) <= rate <= spec.max * (1 + 1e-6):
        hint = (
            "was the data's time in ms, or --ts given in ms? (identify states the time unit it read)"
            if rate < spec.min
            else "identify on data decimated to the board's rate (identify --decimate N)"
        )
        raise ModelError(
            f"the model runs at {rate:.4g} Hz (Ts {ts:.4g} s); the board samples at {spec.min}..{spec.max} Hz: {hint}"
        )


def _check_units(structure: EstimatorStructure) -> None:
    """Refuse a model that looks fitted on dR/100 but does not say so, and one whose inputs
    reached beyond what the board can feed it (16-bit counts of 0.01 % of dR) in identification:
    a model of another quantity, such as a resistance in ohms."""
    limit = 32767 * structure.input_lsb()
    for i, name in enumerate(structure.inputs):
        unit = structure.input_unit(i)
        peak = structure.input_peak[i] if i < len(structure.input_peak) else None
        if peak is not None and np.isfinite(peak) and peak > limit:
            raise ModelError(
                f"input {name} reached {peak:.4g} in identification, beyond the board's input range of "
                f"+-{limit:.6g} ({_unit_words(unit)}): the board feeds its model dR, so a model of another "
                "quantity (a resistance in ohms?) cannot run there; identify it on the board's dR columns"
            )
        if unit is None and peak is not None and 0 < peak <= FRACTION_SUSPECT_PEAK:
            raise ModelError(
                f"input {name} peaked at {peak:.3g} in identification: that is dR/100, not dR in %, "
                "but the model does not say which; declare it (fit(..., input_unit='dR/100') or "
                "porosense quantize --input-unit dR/100)"
            )


def _unit_words(unit) -> str:
    """The input unit as a reader needs it: '% of dR', or what the model states."""
    if unit is None:
        return "% of dR, the unit taken when a model states none"
    return "% of dR" if unit == "%" else str(unit)


def device_inputs(u, input_lsb: float = DEFAULT_INPUT_LSB) -> np.ndarray:
    """What the device feeds its estimator for inputs ``u`` (structure input units, (N, n_in)):
    int64 counts of ``input_lsb``, rounded half away from zero and saturated to int16, as the
    firmware's dR conversion does (sensing.cpp)."""
    v = np.asarray(u, dtype=float) / input_lsb
    return np.clip(np.sign(v) * np.floor(np.abs(v) + 0.5), -32768, 32767).astype(np.int64)


def off_grid(u, input_lsb: float = DEFAULT_INPUT_LSB) -> bool:
    """True when ``u`` is not on the device's input grid, i.e. not a device recording (for
    example a noise-free ground truth or a simulation): the report then rests on inputs the
    device never sees, so it says so."""
    v = np.asarray(u, dtype=float) / input_lsb
    return bool(np.any(np.abs(v - np.round(v)) > 1e-3))


def evaluate(
    structure: EstimatorStructure,
    blob: ModelBlob,
    u: np.ndarray,
    y,
    name: str,
    input_lsb: float = DEFAULT_INPUT_LSB,
    noise_lsb: float = NOISE_PROBE_LSB,
) -> list[RecordingFit]:
    """Fit of the fixed-point reference against the float model and the data, per output.

    Both models run on exactly the device's inputs (:func:`device_inputs`).

    Parameters
    ----------
    structure : EstimatorStructure
        The float model.
    blob : ModelBlob
        Its fixed-point version.
    u : ndarray, shape (N, n_inputs)
        Inputs in structure units (% dR or dR/100).
    y : sequence or None
        Per output, the measured output (N,) in output units, or None where not measured; None
        for no data.
    name : str
        Label of the recording in the report.
    input_lsb : float
        Structure input units per device input LSB (0.01 for dR in %).
    noise_lsb : float
        RMS of the white noise added to the device inputs for the noise probe, device LSB; it
        shows how many fit points sensor noise of that size costs on the device (a model with a
        steep table or a large high-frequency gain amplifies it; 0 skips the probe).

    Returns
    -------
    list of RecordingFit
        One per output.
    """
    counts = device_inputs(u, input_lsb)
    y_float = structure.simulate(counts * input_lsb)
    est, flags = _run_device(blob, counts)
    noisy = None
    if noise_lsb > 0:
        rng = np.random.default_rng(NOISE_PROBE_SEED)
        noisy_counts = device_inputs((counts + rng.normal(0.0, noise_lsb, counts.shape)) * input_lsb, input_lsb)
        noisy, _ = _run_device(blob, noisy_counts)
    out = []
    for j, o in enumerate(structure.outputs):
        y_fixed = est[:, j].astype(float) * blob.out_scale[j]
        yd = None if y is None or y[j] is None else np.asarray(y[j], dtype=float)
        y_noisy = None if noisy is None else noisy[:, j].astype(float) * blob.out_scale[j]
        out.append(
            RecordingFit(
                recording=name,
                output=o.name,
                fit_float_vs_data=None if yd is None else fit_percent(yd, y_float[:, j]),
                fit_fixed_vs_data=None if yd is None else fit_percent(yd, y_fixed),
                fit_fixed_vs_float=fit_percent(y_float[:, j], y_fixed),
                saturated_samples=int(np.count_nonzero(flags)),
                noise_lsb=float(noise_lsb),
                fit_noisy_vs_data=None if yd is None or y_noisy is None else fit_percent(yd, y_noisy),
                fit_noisy_vs_fixed=None if y_noisy is None else fit_percent(y_fixed, y_noisy),
            )
        )
    return out


def _run_device(blob: ModelBlob, counts: np.ndarray):
    full = np.zeros((len(counts), 3), dtype=np.int64)
    full[:, : counts.shape[1]] = counts
    return FixedPointEstimator(blob).run(full)


def _as_recording(r, structure: EstimatorStructure, i: int):
    if isinstance(r, tuple):
        name, u, y = r
        u = np.asarray(u, dtype=float)
        u = u[:, None] if u.ndim == 1 else u
        if y is not None:
            y = np.asarray(y, dtype=float)
            y = [y] if y.ndim == 1 else [y[:, j] for j in range(y.shape[1])]
        return str(name), u, y
    cols = getattr(r, "columns", None)
    cols = cols if isinstance(cols, dict) else r
    names = list(cols.keys())
    missing = [n for n in structure.inputs if n not in names]
    if missing:
        raise InputError(f"recording {i} lacks the model's input column(s) {', '.join(missing)}")
    u = np.column_stack([np.asarray(cols[n], dtype=float) for n in structure.inputs])
    y = [np.asarray(cols[o.name], dtype=float) if o.name in names else None for o in structure.outputs]
    meta = getattr(r, "meta", {}) or {}
    name = str(meta.get("name") or meta.get("experiment") or getattr(r, "path", None) or f"recording {i}")
    return name, u, y


def _input_ranges(structure, recs, input_range, lsb) -> list[tuple[float, float]]:
    n = len(structure.inputs)
    dev_lo, dev_hi = -32768 * lsb, 32767 * lsb
    if input_range is not None:
        arr = np.asarray(input_range, dtype=float)
        pairs = [tuple(arr)] * n if arr.shape == (2,) else [tuple(p) for p in arr]
        if len(pairs) != n or any(lo >= hi for lo, hi in pairs):
            raise InputError(f"input_range needs (lo, hi) with lo < hi, once or per input ({n})")
    elif recs:
        u = np.concatenate([r[1] for r in recs], axis=0)
        lo, hi = np.min(u, axis=0), np.max(u, axis=0)
        for r in recs:  # data the board cannot take are data of another quantity or unit
            beyond = np.flatnonzero(np.max(np.abs(r[1]), axis=0) > dev_hi)
            if beyond.size:
                k = int(beyond[0])
                unit = structure.input_unit(k)
                raise InputError(
                    f"{r[0]}: input {structure.inputs[k]} reaches {np.max(np.abs(r[1][:, k])):.4g}, beyond the board's "
                    f"input range of +-{dev_hi:.6g} ({_unit_words(unit)}): the board feeds its model dR, not "
                    "this quantity (a resistance in ohms?)"
                )
        # At least 1 % of dR (100 device LSB) of span: a floor in the structure's own unit
        # would widen a range given in fractions (input_lsb 1e-4) a hundredfold too much.
        span = np.maximum(hi - lo, 100.0 * lsb)
        pairs = list(zip(lo - 0.25 * span, hi + 0.25 * span))
    elif len(structure.input_peak) == n and all(np.isfinite(p) and p > 0 for p in structure.input_peak):
        # The model's own range: +- the largest |input| seen in identification, widened like data.
        pairs = [(-1.5 * float(p), 1.5 * float(p)) for p in structure.input_peak]
    else:  # DEFAULT_INPUT_RANGE is in % of dR; lsb / 0.01 converts % to structure units
        pairs = [tuple(v * lsb / DEFAULT_INPUT_LSB for v in DEFAULT_INPUT_RANGE)] * n
    return [(max(float(lo), dev_lo), min(float(hi), dev_hi)) for lo, hi in pairs]
