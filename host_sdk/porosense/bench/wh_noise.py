"""The measured WH process-noise benchmark, part by part (``porosense bench ident --only builds|whsearch``).

builds    every process-noise build of ``identify --process-noise`` side by side: the output-error
          builds of WH at one order (BLA split, Wiener + linear, linear + Hammerstein, their starts),
          each refined with its noise level measured from the repeated periods; per build its
          expected-output error relative to the lowest (the tie rule keeps the fewest parameters
          within one standard error), the level (x the spread of g's input), the noise-free test
          RMSE on the multisine (mV), the colour check (:mod:`porosense.ident.noise_colour`) and the
          RMS distance (mV) of its noise-free output on the estimation inputs from the kept build;
          then the output-error builds' test RMSE and the deconvolution check of the kept build
          (:func:`porosense.ident.process_noise.deconvolution_spread`).
whsearch  the default staged order search of ``identify --process-noise`` (the paper's grid, 10
          breakpoints, selection by the validation fit) on a range of realisations, validated on the
          next one (or the one before when the range ends at the last): the search table, and the
          test RMSE of each structure's best candidate, of the refits with process noise and of the
          selected model.

Options (:class:`Options`): the realisations (``A-B``), the order (poles, zeros; builds), the
starts per nonlinear model, the evaluations per fit, the structures and pole counts (whsearch).
"""

from __future__ import annotations

import resource
import time
from dataclasses import dataclass
from functools import partial

import numpy as np

from porosense.data import read_table
from porosense.errors import InputError
from porosense.ident import STRUCTURES

SKIP = 200  # samples: the transient left out of every cost and error
N_REALISATIONS = 10


@dataclass(frozen=True)
class Options:
    """What the two parts run on.

    Parameters
    ----------
    realisations : tuple of int
        Estimation realisations of the benchmark (0-9).
    order : tuple of int
        (poles, zeros) of the WH builds (builds only).
    starts : int or None
        Starts per nonlinear model (None: 1 for builds, 2 for whsearch, as ``identify`` runs it).
    evaluations : int
        Cost evaluations per fit (least-squares ``max_nfev``).
    structures : tuple of str
        Structures of the order search (whsearch only).
    poles : tuple of int or None
        Pole counts of the order search (whsearch only; None: the paper's 1..10).
    """

    realisations: tuple = (0, 1, 2, 3, 4)
    order: tuple = (6, 3)
    starts: int | None = None
    evaluations: int = 200
    structures: tuple = STRUCTURES
    poles: tuple | None = None


def parse_realisations(text: str) -> tuple:
    """Realisation indices from ``N`` (the first N) or ``A-B`` (A to B, both included)."""
    try:
        if "-" in text:
            lo, hi = (int(v) for v in text.split("-"))
            which = tuple(range(lo, hi + 1))
        else:
            which = tuple(range(int(text)))
    except ValueError:
        raise InputError(f"realisations '{text}': give N or A-B (0-{N_REALISATIONS - 1})") from None
    if not which or min(which) < 0 or max(which) >= N_REALISATIONS:
        raise InputError(f"realisations '{text}': N from 1 to {N_REALISATIONS} or A-B within 0-{N_REALISATIONS - 1}")
    return which


def parse_order(text: str) -> tuple:
    """(poles, zeros) from ``P,Z``."""
    try:
        poles, zeros = (int(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"order '{text}': give poles,zeros (e.g. 6,3)") from None
    if poles < 1 or not 0 <= zeros < poles:
        raise InputError(f"order '{text}': need poles >= 1 and 0 <= zeros < poles")
    return poles, zeros


def _cpu() -> float:
    """CPU seconds of this process and of its finished (waited-for) worker processes."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _records(folder, which):
    """(us, ys, test u, test y): the realisations ``which`` ((N, 1) inputs, V) and the test multisine."""
    est = read_table(folder / "wh_process_noise" / "WH_EstimationExample.csv")
    test = read_table(folder / "wh_process_noise" / "WH_TestDataset.csv")
    us = [est.columns[f"u_{i}"][:, None] for i in which]
    ys = [est.columns[f"y_{i}"] for i in which]
    return us, ys, test.columns["u_0"][:, None], test.columns["y_0"], 1.0 / float(est.columns["fs"][0])


def builds(folder, opts: Options) -> dict:
    """Every process-noise build at one order, side by side (see the module's text); mV and %."""
    from porosense.ident import noise_level, output_error, process_noise, refine, rmse
    from porosense.ident.chain import Chain
    from porosense.ident.metrics import relative_standard_error

    us, ys, ut, yt, _ = _records(folder, opts.realisations)
    t0, c0 = time.perf_counter(), _cpu()
    scale = np.max(np.abs(np.vstack(us)), axis=0)
    all_y = np.concatenate(ys)
    mean, std = float(np.mean(all_y)), float(np.std(all_y))
    nus, nys = [u / scale for u in us], [(y - mean) / std for y in ys]
    ropts = refine.Options(skip=SKIP, starts=opts.starts or 1, max_nfev=opts.evaluations)
    oe = output_error.wh_fits(nus, nys, *opts.order, 10, 0, ropts)
    periods = noise_level.PeriodData(nus, nys, SKIP)
    fits = process_noise.map_builds(
        partial(process_noise.noise_from_periods, us=nus, ys=nys, opts=ropts, periods=periods), oe
    )
    low = min(f.sse for f in fits)
    n_res = sum(len(y) - SKIP for y in ys)
    tied = process_noise.within_noise([f for f in fits if f.notes["process_noise"]["consistent"]], n_res)
    kept = min(tied, key=lambda f: (f.spec.n_params, f.sse)) if tied else None

    def noise_free(f, u):
        return Chain(f.spec, f.theta).simulate(u / scale, expected=False) * std + mean

    def distance_mv(f) -> float:
        if kept is None:
            return float("nan")
        d = np.concatenate([(noise_free(f, u) - noise_free(kept, u))[SKIP:] for u in us])
        return float(np.sqrt(np.mean(d**2))) * 1e3

    rows = []
    for f in fits:
        pn = f.notes["process_noise"]
        rows.append(
            {
                "build": f.build,
                "kept": f is kept,
                "parameters": f.spec.n_params,
                "error_above_lowest_pct": 100 * (f.sse / low - 1),
                "level_per_spread": pn["sigma_per_spread"],
                "consistent": bool(pn["consistent"]),
                "test_rmse_mV": rmse(yt[SKIP:], noise_free(f, ut)[SKIP:]) * 1e3,
                "from_kept_mV": distance_mv(f),
                "colour_statistic": pn["colour"]["statistic"],
                "colour_dof": pn["colour"]["dof"],
                "colour_p": pn["colour"]["p_value"],
            }
        )
    out = {
        "realisations": list(opts.realisations),
        "order": list(opts.order),
        "starts": opts.starts or 1,
        "evaluations": opts.evaluations,
        "tie_pct": 200 * relative_standard_error(n_res),
        "builds": rows,
        "output_error_test_rmse_mV": {f.build: rmse(yt[SKIP:], noise_free(f, ut)[SKIP:]) * 1e3 for f in oe},
    }
    if kept is not None:
        parent = oe[next(i for i, f in enumerate(fits) if f is kept)]  # by identity: fits hold arrays
        d = process_noise.deconvolution_spread(kept, parent, tied, nus, SKIP)
        out["deconvolution"] = {
            "correction_mV": d["correction"] * std * 1e3,
            "spread_mV": d["spread"] * std * 1e3,
            "tied_builds": d["tied_builds"],
            "determined": bool(d["determined"]),
        }
    out["wall_s"], out["cpu_s"] = time.perf_counter() - t0, _cpu() - c0
    return out


def _span(which: list) -> str:
    """``A-B`` for a range of realisations, ``A`` for one."""
    return f"{which[0]}-{which[-1]}" if len(which) > 1 else f"{which[0]}"


def builds_lines(r: dict) -> list[str]:
    """The builds part's figures, one line each."""
    which = r["realisations"]
    s = [
        f"WH process-noise builds, realisations {_span(which)}, {r['order'][0]}p{r['order'][1]}z, "
        f"{r['starts']} start(s), {r['evaluations']} evaluations; tie: within {r['tie_pct']:.2f} % of the lowest "
        f"error; {r['cpu_s']:.0f} s CPU, {r['wall_s']:.0f} s wall"
    ]
    for b in r["builds"]:
        s.append(
            f"{'*' if b['kept'] else ' '} {b['build']}: {b['parameters']} parameters, error "
            f"{b['error_above_lowest_pct']:+.2f} %, level {b['level_per_spread']:.2f}"
            f"{'' if b['consistent'] else ' (period power refuted)'}, test RMSE {b['test_rmse_mV']:.2f} mV, "
            f"noise-free {b['from_kept_mV']:.2f} mV from the kept build, colour misfit {b['colour_statistic']:.1f} "
            f"on {b['colour_dof']} dof (p = {b['colour_p']:.2g})"
        )
    for build, mv in r["output_error_test_rmse_mV"].items():
        s.append(f"  output error {build}: test RMSE {mv:.2f} mV")
    d = r.get("deconvolution")
    if d is not None:
        s.append(
            f"deconvolution check of the kept build: moved {d['correction_mV']:.2f} mV from its output-error fit, "
            f"spread {d['spread_mV']:.2f} mV over {d['tied_builds']} tied builds: "
            f"{'determined, kept' if d['determined'] else 'undetermined, the output-error fit stays'}"
        )
    return s


def whsearch(folder, opts: Options) -> dict:
    """The default staged search with process noise on ``opts.realisations`` (the next realisation
    validates, or the one before when they end at the last); test RMSE in mV."""
    from porosense.ident import rmse, search

    which = list(opts.realisations)
    extra = which[-1] + 1 if which[-1] < N_REALISATIONS - 1 else which[0] - 1
    if extra < 0:
        raise InputError("whsearch needs one realisation outside the range to validate on")
    us, ys, ut, yt, ts = _records(folder, which + [extra])
    n = len(which)
    t0, c0 = time.perf_counter(), _cpu()
    res = search(
        u=us[:n],
        y=ys[:n],
        ts=ts,
        validation=(us[n:], ys[n:]),
        validation_skip=SKIP,
        skip=SKIP,
        structures=tuple(opts.structures),
        **({"poles": tuple(opts.poles)} if opts.poles else {}),
        n_breakpoints=10,
        starts=opts.starts or 2,
        max_nfev=opts.evaluations,
        criterion="fit",
        staged=True,
        process_noise=True,
        progress=False,
    )
    wall, cpu = time.perf_counter() - t0, _cpu() - c0

    def test_mv(model) -> float:
        return rmse(yt[SKIP:], np.asarray(model.predict(u=ut)).ravel()[SKIP:]) * 1e3

    def name(c) -> str:
        return f"{c.structure} {c.n_poles}p{c.n_zeros}z"

    best = {
        s: {
            "order": f"{c.n_poles}p{c.n_zeros}z",
            "process_noise": bool(c.model.spec.g_noise),
            "validation_fit": c.validation_fit,
            "test_rmse_mV": test_mv(c.model),
        }
        for s, c in res.best_per_structure("fit").items()
    }
    refits = [
        {"candidate": name(c), "validation_fit": c.validation_fit, "test_rmse_mV": test_mv(c.model)}
        for c in res.candidates
        if c.model.spec.g_noise
    ]
    return {
        "realisations": which,
        "validation": extra,
        "structures": list(opts.structures),
        "poles": list(opts.poles) if opts.poles else "1-10",
        "starts": opts.starts or 2,
        "evaluations": opts.evaluations,
        "table": str(res),
        "best_per_structure": best,
        "process_noise_refits": refits,
        "selected": name(res.best),
        "selected_test_rmse_mV": test_mv(res.model),
        "wall_s": wall,
        "cpu_s": cpu,
    }


def whsearch_lines(r: dict) -> list[str]:
    """The whsearch part's figures: the search table, then one line per figure."""
    which = r["realisations"]
    s = [r["table"]]
    s.append(
        f"WH process-noise default search on realisations {_span(which)} (validation on "
        f"{r['validation']}), {', '.join(r['structures'])}, poles {r['poles'] if isinstance(r['poles'], str) else ', '.join(map(str, r['poles']))}, {r['starts']} start(s), {r['evaluations']} "
        f"evaluations: {r['cpu_s']:.0f} s CPU, {r['wall_s']:.0f} s wall"
    )
    for structure, b in r["best_per_structure"].items():
        noise = " (process noise)" if b["process_noise"] else ""
        s.append(
            f"{structure} {b['order']}{noise}: validation fit {b['validation_fit']:.2f} %, "
            f"test RMSE {b['test_rmse_mV']:.2f} mV"
        )
    for c in r["process_noise_refits"]:
        s.append(
            f"refitted with process noise: {c['candidate']}, validation fit {c['validation_fit']:.2f} %, "
            f"test RMSE {c['test_rmse_mV']:.2f} mV"
        )
    s.append(f"selected {r['selected']}: test RMSE {r['selected_test_rmse_mV']:.2f} mV")
    return s
