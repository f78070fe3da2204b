"""Closed loop versus the open-loop baseline under load: the core of ``porosense bench control``.

1. At 0 g, the paper's experiments on the simulated contractor (staircase, -10 and -60 kPa
   steps for estimation; -20 and -40 kPa for the quantizer's scaling) give the on-board WH
   model (2 poles, 1 zero, 10 breakpoints), the FOPDT plant and the lambda-tuned PI gains, all
   from data the controller never saw. Optionally the estimator also learns from the same
   estimation experiments under other loads (``model_loads``).
2. The open-loop baseline is what users do today: the steady-state strain-vs-vacuum map
   measured at 0 g (holds every 5 kPa, settled true strain), inverted: the vacuum for a target
   is the map's.
3. Per load (0, 200, 500 g) on the emulator (the firmware's core over the simulator): step
   targets across the stroke, held; closed loop (the board's controller on its estimate) and
   open loop (the map's vacuum). The error is the simulator's TRUE strain minus the target,
   averaged over the last quarter of each hold (steady state).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from porosense.boards import open_board
from porosense.control.metrics import step_metrics
from porosense.control.plant import Fopdt, fit_fopdt
from porosense.control.runner import prepare_board
from porosense.control.session import check_not_vented, run_closed_loop, run_open_loop
from porosense.control.staticmap import StaticMap, static_map
from porosense.control.tuning import DEFAULT_TAU_CL_S, PiGains, board_tau_cl, lambda_pi
from porosense.ident import WienerHammerstein, fit_percent
from porosense.quant import quantize
from porosense.sim import run_experiment
from porosense.sim.schedules import Schedule
from porosense.sim.steady import steady_state

OUTPUT = "strain_0"
LOADS_G = (0.0, 200.0, 500.0)
#: Targets (% strain) across the contractor's stroke (26 % at -60 kPa unloaded, 22 % under
#: 500 g), in an order that steps both up and down.
TARGETS = {"small": (8.0, 16.0, 12.0), "full": (4.0, 12.0, 20.0, 8.0, 16.0)}
HOLD_S = {"small": 8.0, "full": 12.0}
MAP_STEP_KPA = 5.0
MAP_HOLD_S = 8.0


@dataclass
class Setup:
    """What the identification produced: ``blob`` (the WH model, bytes), ``plant``,
    ``gains``, ``smap`` (the 0 g static map), ``rate_hz``, ``model_fit`` (validation fit %)."""

    blob: bytes
    plant: Fopdt
    gains: PiGains
    smap: StaticMap
    rate_hz: int
    model_fit: float
    seconds: float


def identify_setup(
    rate_hz: int = 50,
    seed: int = 100,
    tau_cl_s: float | None = None,
    slew_per_s: float = 20.0,
    model_loads=(0.0,),
    physics=None,
) -> Setup:
    """Everything the controller and the baseline need, from simulations (see module doc).

    ``model_loads`` (g): the loads of the recordings the on-board estimator is identified on
    (each the same three estimation experiments, new seeds); the plant, the gains and the open
    loop's static map stay those of 0 g. ``physics``: the simulator's parameters
    (porosense.sim.Physics; default its defaults)."""

    t0 = time.perf_counter()
    ts = 1.0 / rate_hz
    names = ("staircase", "step_10", "step_60", "step_20", "step_40")
    recs = [
        run_experiment("contractor", e, load_g=0.0, rate_hz=rate_hz, seed=seed + i, physics=physics)
        for i, e in enumerate(names)
    ]
    est, val = recs[:3], recs[3:]
    est = est + [
        run_experiment("contractor", e, load_g=float(L), rate_hz=rate_hz, seed=seed + 50 + 10 * j + i, physics=physics)
        for j, L in enumerate(model_loads)
        if L != 0.0
        for i, e in enumerate(names[:3])
    ]
    model = WienerHammerstein(n_poles=2, n_zeros=1, n_breakpoints=10)
    model.fit(u=[r["dR_0"][:, None] / 100 for r in est], y=[r[OUTPUT] for r in est], ts=ts, input_unit="dR/100")
    fit = float(np.mean([fit_percent(r[OUTPUT], model.predict(u=r["dR_0"][:, None] / 100)) for r in val]))
    q = quantize(
        model.to_structure(),
        recordings=[(f"v{i}", r["dR_0"][:, None] / 100, r[OUTPUT][:, None]) for i, r in enumerate(val)],
    )
    plant = fit_fopdt([-r["p_cmd_0"] for r in recs], [r[OUTPUT] for r in recs], ts, output_unit="%")
    blob = q.blob
    tau = board_tau_cl(
        plant, DEFAULT_TAU_CL_S if tau_cl_s is None else tau_cl_s, slew_per_s, float(blob.out_scale[0]), rate_hz
    )
    gains = lambda_pi(plant, tau, slew_per_s)
    smap = measure_static_map(rate_hz, seed=seed + 10, physics=physics)
    return Setup(q.blob.to_bytes(), plant, gains, smap, rate_hz, fit, time.perf_counter() - t0)


def map_schedule(step_kpa: float = MAP_STEP_KPA, hold_s: float = MAP_HOLD_S, top_kpa: float = 60.0):
    """Holds at 0, step, 2 step, ... top kPa of vacuum, ``hold_s`` each, after a 5 s rest."""

    levels = np.arange(step_kpa, top_kpa + 1e-9, step_kpa)
    changes = tuple((5.0 + i * hold_s, -float(v)) for i, v in enumerate(levels))
    end = 5.0 + len(levels) * hold_s
    return Schedule("static_map", end + 5.0, (changes + ((end, 0.0),), (), ()), "holds for the static map")


def measure_static_map(rate_hz: int, seed: int = 0, load_g: float = 0.0, physics=None) -> StaticMap:
    """The settled true strain at each hold of :func:`map_schedule` on the simulated contractor."""

    rec = run_experiment("contractor", map_schedule(), load_g=load_g, rate_hz=rate_hz, seed=seed, physics=physics)
    return static_map([(rec.t, -rec["p_cmd_0"], rec[OUTPUT])])


def _segments(targets, hold_s, lead_s=1.0):
    return [(lead_s + i * hold_s, float(v)) for i, v in enumerate(targets)]


def steady_errors(rec, segments, hold_s, lead_s=1.0, *, board_timed: bool = False) -> list[dict]:
    """Per held target: step metrics against the truth (the simulator's strain). Open-loop
    recordings are time-aligned by construction (t = planned time: the holds are streamed
    back to back, each from its command); closed-loop switches are timed by the board from
    its start, read from its target column (``board_timed``)."""
    t = rec.t
    shift = 0.0
    if board_timed:
        on = np.isfinite(rec["target_0"])
        shift = float(t[np.argmax(on)]) - float(segments[0][0]) if on.any() else 0.0
    out = []
    prev = float(np.mean(rec[OUTPUT][t < lead_s + shift])) if np.any(t < lead_s + shift) else 0.0
    for t0, v in segments:
        m = step_metrics(t, v, rec[OUTPUT], t0 + shift, hold_s, prev)
        out.append(m.to_dict())
        prev = v
    return out


def measure_load(
    setup: Setup, load_g: float, targets, hold_s: float, *, seed: int = 0, port: str = "emulator", physics=None
) -> dict:
    """Closed and open loop for one load on a fresh simulated board; errors against the truth.
    ``physics``: the simulated board's parameters (porosense.sim.Physics; default its defaults)."""

    segs = _segments(targets, hold_s)
    vac = [float(setup.smap.vacuum_for(v)) for v in targets]
    t0 = time.perf_counter()
    with open_board(port, load_g=load_g, seed=seed, physics=physics) as board:
        dev, truth = board.device, board.truth
        rate, scale = prepare_board(dev, simulated=True, model=setup.blob, gains=setup.gains)
        duration = segs[-1][0] + hold_s
        closed = run_closed_loop(
            dev,
            segs,
            rate_hz=rate,
            out_scale=scale,
            output=OUTPUT,
            truth=truth,
            duration_s=duration,
            meta={"load_g": load_g},
        )
        # back to rest before the baseline (the foam's creep and the network relaxation)
        run_open_loop(dev, [(0.0, 0.0)], rate_hz=rate, out_scale=scale, truth=truth, duration_s=5.0)
        opened = run_open_loop(
            dev,
            [(0.0, 0.0)] + [(t, p) for (t, _), p in zip(segs, vac)],
            rate_hz=rate,
            out_scale=scale,
            truth=truth,
            duration_s=duration,
            targets=[np.nan, *targets],
            meta={"load_g": load_g},
        )
    for rec in (closed, opened):
        check_not_vented(rec)
    cl = steady_errors(closed, segs, hold_s, board_timed=True)
    ol = steady_errors(opened, [(0.0, 0.0)] + segs, hold_s)[1:]
    cl_err = float(np.mean([abs(m["steady_error"]) for m in cl]))
    ol_err = float(np.mean([abs(m["steady_error"]) for m in ol]))
    est_bias = float(np.nanmean(closed[f"est_{OUTPUT}"] - closed[OUTPUT]))
    floor = load_floor(targets, load_g)
    return {
        "load_g": load_g,
        "floor": floor,
        "floor_steady_error": float(np.mean(np.abs(floor))),
        "closed_loop": cl,
        "open_loop": ol,
        "vacuum_open_loop_kpa": vac,
        "closed_steady_error": cl_err,
        "open_steady_error": ol_err,
        "ratio": cl_err / ol_err if ol_err > 0 else float("nan"),
        "estimate_bias": est_bias,
        "seconds": time.perf_counter() - t0,
        "recordings": {"closed": closed, "open": opened},
    }


def run_loads(size: str = "small", loads=LOADS_G, *, rate_hz: int = 50, seed: int = 100, model_loads=(0.0,)) -> dict:
    """The whole comparison; figures in % strain (see the module docstring). ``model_loads``:
    the loads (g) of the estimator's identification recordings (see identify_setup)."""
    setup = identify_setup(rate_hz, seed=seed, model_loads=model_loads)
    per = [measure_load(setup, L, TARGETS[size], HOLD_S[size], seed=seed + 20 + i) for i, L in enumerate(loads)]
    return {"setup": setup, "loads": per}


def load_floor(targets, load_g: float, *, step_kpa: float = 0.25) -> list[float]:
    """The steady-state error (true - target, % strain) a perfect closed loop on a perfect 0 g
    estimator would leave under ``load_g``: from the simulator's steady-state solution alone
    (porosense.sim.steady_state), the vacuum at which the 0 g dR-to-strain map reads each
    target under the load, and the true strain there. Independent of the controller and of the
    identified model: it is the share of the error that the load's effect on the resistance
    (contacts held open, porosense.sim.params.Piezo load_contact_coupling) puts beyond feedback."""

    ps = np.arange(0.0, 80.0 + 1e-9, step_kpa)
    m0 = np.array([[steady_state("contractor", vacuum_kpa=-p)[k] for k in ("strain_pct", "dR_pct")] for p in ps])
    ml = np.array(
        [[steady_state("contractor", load_g=load_g, vacuum_kpa=-p)[k] for k in ("strain_pct", "dR_pct")] for p in ps]
    )
    # dR falls monotonically with vacuum: read the 0 g map at the loaded dR
    est = np.interp(-ml[:, 1], -m0[:, 1], m0[:, 0])
    out = []
    for v in targets:
        p = np.interp(v, est, ps)
        out.append(float(np.interp(p, ps, ml[:, 0]) - v))
    return out
