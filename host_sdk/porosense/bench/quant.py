"""Quantization figures: fixed-point fit loss, blob sizes, the EEPROM refusal, Python
reference speed and the AVR cycle count of the estimator step (simavr).

    porosense bench quant --json
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from porosense.errors import ModelError
from porosense.firmware import avr_cycles
from porosense.protocol.model_blob import MAX_BLOB_LEN
from porosense.protocol.model_layout import FLASH_BLOB_MAX
from porosense.quant import FixedPointEstimator, quantize
from porosense.quant.design import design_blob
from porosense.quant.random_models import random_structure, step_inputs
from porosense.structure import PiecewiseLinear, SOSCascade

CYCLE_BUDGET = 48_000


def _fit_figures(n_models: int, n_samples: int) -> dict:

    losses, fixed_vs_float, sats = [], [], 0
    kinds = ("linear", "hammerstein", "wiener", "wh")
    for i in range(n_models):
        rng = np.random.default_rng(100 + i)
        s = random_structure(rng, 1, 1, h1_poles=int(rng.integers(2, 7)), h2_poles=2, kind=kinds[i % 4])
        est_u, val_u = step_inputs(rng, n_samples), step_inputs(rng, n_samples)
        y = s.simulate(val_u)[:, 0]
        y = y + rng.normal(0, 0.05 * np.std(y), len(y))
        r = quantize(s, recordings=[("estimation", est_u, None), ("validation", val_u, y)])
        for f in r.report.fits:
            fixed_vs_float.append(f.fit_fixed_vs_float)
            if f.loss_points is not None:
                losses.append(abs(f.loss_points))
            sats += f.saturated_samples
    return {
        "models": n_models,
        "samples_per_recording": n_samples,
        "max_fit_loss_points": max(losses),
        "min_fit_fixed_vs_float": min(fixed_vs_float),
        "saturated_samples": sats,
    }


def _worst_case_structure():

    return random_structure(np.random.default_rng(1), 3, 3, h1_poles=10, h2_poles=10, breakpoints=16, kind="wh")


def _largest_fitting(structure):
    """The worst-case structure cut to the largest uniform orders that fit the EEPROM."""

    def cut(s1, s2, bp):
        outs = []
        for o in structure.outputs:
            brs = tuple(
                replace(
                    b,
                    h1=SOSCascade(b.h1.sos[-s1:]),
                    f=PiecewiseLinear(b.f.x[:bp], b.f.y[:bp]) if b.f is not None else None,
                )
                for b in o.branches
            )
            outs.append(
                replace(o, branches=brs, h2=SOSCascade(o.h2.sos[-s2:]), g=PiecewiseLinear(o.g.x[:bp], o.g.y[:bp]))
            )
        return replace(structure, outputs=tuple(outs))

    for s1, s2, bp in ((3, 3, 10), (3, 2, 10), (2, 2, 10), (2, 2, 8), (2, 1, 8), (1, 1, 8)):
        try:
            # A cost benchmark of random coefficients, not a model for a board: the checks of a
            # fixed-point fit against the float model would refuse some cuts (force keeps the size limit).
            return quantize(cut(s1, s2, bp), input_range=(-100, 100), force=True), (2 * s1, 2 * s2, bp)
        except ModelError:
            continue
    raise ModelError("no cut of the worst-case structure fits")


def _most_sections_that_fit():
    """The storable model with the most sections (the device's real cycle worst case): 3x3 with
    H1 and H2 but no tables, H2 then H1 cut until the blob fits."""

    # H2 cut first, then H1, until the blob fits the model area (776 B since the controller's
    # gains and trajectory took the top of the EEPROM).
    for h1, h2 in ((10, 10), (10, 8), (10, 6), (10, 4), (10, 2), (8, 2), (6, 2)):
        s = random_structure(np.random.default_rng(1), 3, 3, h1_poles=h1, h2_poles=h2, kind="wh")
        s = replace(
            s,
            outputs=tuple(
                replace(o, g=None, branches=tuple(replace(b, f=None) for b in o.branches)) for o in s.outputs
            ),
        )
        try:
            return quantize(s, input_range=(-100, 100), force=True)  # cost benchmark, as above
        except ModelError:
            continue
    raise ModelError("no table-free 3x3 model fits")


def _paper_set_sizes(n_seeds: int) -> dict:
    """Blob sizes (B) of the paper's 3-DoF model set (three 3-input WH models, f + H1 + g + H2, 2
    poles per block, 10 breakpoints; random structures, seeds 0..n_seeds-1) quantised on
    (-90, 10) % dR with full tables (no capacity limit) and for a flash slot (compact tables
    when full ones do not fit)."""
    full, slot = [], []
    for seed in range(n_seeds):
        s = random_structure(np.random.default_rng(seed), 3, 3, h1_poles=2, h2_poles=2, breakpoints=10, kind="wh")
        full.append(quantize(s, input_range=(-90.0, 10.0), capacity=4096, noise_lsb=0).blob.length)
        slot.append(quantize(s, input_range=(-90.0, 10.0), capacity=FLASH_BLOB_MAX, noise_lsb=0).blob.length)
    return {
        "seeds": n_seeds,
        "full_tables_bytes": [min(full), max(full)],
        "flash_slot_bytes": [min(slot), max(slot)],
        "flash_slot_capacity": FLASH_BLOB_MAX,
        "fit_eeprom_alone": sum(n <= MAX_BLOB_LEN for n in slot),
    }


def run(size: str = "small") -> dict:

    full = size == "full"
    out: dict = {"size": size}
    out.update(_fit_figures(16 if full else 4, 20_000 if full else 4_000))

    worst = _worst_case_structure()
    try:
        quantize(worst, input_range=(-100, 100))
        out["worst_case_refusal"] = None
    except ModelError as exc:
        out["worst_case_refusal"] = str(exc)
    notes: list[str] = []
    worst_blob, _ = design_blob(worst, [(-100.0, 100.0)] * 3, 0.01, 1, notes)
    out["worst_case_blob_bytes"] = worst_blob.length
    fitting, orders = _largest_fitting(worst)
    out["paper_3dof_set"] = _paper_set_sizes(20)  # 1.5 s of CPU: the same in both sizes
    out["largest_fitting_3dof"] = {
        "h1_poles": orders[0],
        "h2_poles": orders[1],
        "breakpoints": orders[2],
        "blob_bytes": fitting.blob.length,
        "capacity": MAX_BLOB_LEN,
    }

    # Python reference speed on a one-output WH model and on the 3x3 worst case.
    n = 100_000 if full else 10_000
    rng = np.random.default_rng(5)
    u = rng.integers(-9000, 500, (n, 3))
    for name, blob in (
        ("wh_1x1", quantize(_one_output(), input_range=(-100, 100), force=True).blob),
        ("fitting_3x3", fitting.blob),
    ):
        est = FixedPointEstimator(blob)
        t0 = time.perf_counter()
        est.run(u)
        out[f"python_samples_per_s_{name}"] = n / (time.perf_counter() - t0)

    missing = avr_cycles.available()
    if missing:
        out["avr"] = {"skipped": f"missing {missing}"}
    else:
        steps = 64 if full else 16
        w = avr_cycles.measure(worst_blob, steps=steps)
        e = avr_cycles.measure(fitting.blob, steps=steps, in_eeprom=True)
        most = _most_sections_that_fit().blob
        m = avr_cycles.measure(most, steps=steps, in_eeprom=True)
        out["avr"] = {
            "worst_case_cycles": w.max_cycles,
            "worst_case_mean_cycles": w.mean_cycles,
            "worst_case_from": "flash (the blob exceeds the EEPROM)",
            "worst_case_bit_exact": w.bit_exact,
            "eeprom_model_cycles": e.max_cycles,
            "eeprom_model_bit_exact": e.bit_exact,
            "eeprom_most_sections": most.n_sections,
            "eeprom_most_sections_bytes": most.length,
            "eeprom_most_sections_cycles": m.max_cycles,
            "eeprom_most_sections_bit_exact": m.bit_exact,
            "control_cycles": m.control_cycles,
            "eeprom_most_sections_with_control_cycles": m.sample_cycles,
            "estimator_ram_bytes": w.estimator_ram,
            "budget_cycles": CYCLE_BUDGET,
        }
    out["summary"] = _summary(out)
    return out


def _one_output():

    return random_structure(np.random.default_rng(3), 1, 1, h1_poles=6, h2_poles=2, breakpoints=10, kind="wh")


def _summary(r: dict) -> list[str]:
    lines = [
        f"fixed-point vs float: max fit loss {r['max_fit_loss_points']:.3f} points, min fit fixed vs float "
        f"{r['min_fit_fixed_vs_float']:.2f} % over {r['models']} random models; saturated samples "
        f"{r['saturated_samples']}",
        f"worst case 3x3 (10+10 poles, 16 breakpoints): {r['worst_case_blob_bytes']} bytes -> "
        + ("refused: " + r["worst_case_refusal"] if r["worst_case_refusal"] else "fits"),
        "largest fitting 3x3 WH: H1 {h1_poles} poles, H2 {h2_poles} poles, {breakpoints} breakpoints, "
        "{blob_bytes}/{capacity} bytes".format(**r["largest_fitting_3dof"]),
        "paper 3-DoF set ({seeds} seeds): full tables {full_tables_bytes[0]}..{full_tables_bytes[1]} B, for a "
        "{flash_slot_capacity}-byte flash slot {flash_slot_bytes[0]}..{flash_slot_bytes[1]} B; the EEPROM "
        "area alone holds {fit_eeprom_alone}".format(**r["paper_3dof_set"]),
        f"Python reference: {r['python_samples_per_s_wh_1x1']:.0f} samples/s (1x1 WH), "
        f"{r['python_samples_per_s_fitting_3x3']:.0f} samples/s (3x3)",
    ]
    avr = r["avr"]
    if "skipped" in avr:
        lines.append(f"AVR cycles: skipped ({avr['skipped']})")
    else:
        lines.append(
            f"AVR step, worst case (from flash): {avr['worst_case_cycles']} cycles (budget "
            f"{avr['budget_cycles']}), bit-exact {avr['worst_case_bit_exact']}"
        )
        lines.append(
            f"AVR step, largest EEPROM WH model: {avr['eeprom_model_cycles']} cycles, bit-exact "
            f"{avr['eeprom_model_bit_exact']}; estimator RAM {avr['estimator_ram_bytes']} bytes"
        )
        lines.append(
            f"AVR step, most sections in the EEPROM ({avr['eeprom_most_sections']} sections, "
            f"{avr['eeprom_most_sections_bytes']} bytes): {avr['eeprom_most_sections_cycles']} cycles, "
            f"bit-exact {avr['eeprom_most_sections_bit_exact']}"
        )
        lines.append(
            f"AVR strain controller step, 3 channels: {avr['control_cycles']} cycles; with the most "
            f"sections: {avr['eeprom_most_sections_with_control_cycles']} cycles (budget "
            f"{avr['budget_cycles']})"
        )
    return lines
