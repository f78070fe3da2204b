"""Process noise at g's input: a Wiener or WH output-error fit refined as a model whose noise enters
before its static map g, so that g is learnt noise-free instead of noise-smoothed.

The level comes from the repeated periods of the input when the recordings have them
(:mod:`noise_level`), else from the averaged output alone. Normalised data as in :mod:`refine`.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures.process import BrokenProcessPool
from dataclasses import replace
from functools import partial

import numpy as np

from porosense.ident import blocks, noise_colour, noise_level
from porosense.ident.chain import Chain, ChainSpec, block_filter
from porosense.ident.metrics import relative_standard_error
from porosense.ident.refine import Fit, Options, lstsq, multistart, refine, sse
from porosense.ident.workers import local_pool, stop

# Starting standard deviations of the process noise, as fractions of the spread (standard
# deviation) of g's input: from barely noticeable to larger than the signal itself.
NOISE_STARTS = (0.05, 0.15, 0.3, 0.5, 0.8, 1.2)


def _noise_start(spec: ChainSpec, theta, us, ys, skip: int) -> np.ndarray:
    """``theta`` with g's values and the offset re-solved by least squares for its sigma.

    The expected output is linear in g's values once H1, H2, the breakpoints and sigma are
    held, so each sigma gets the g that best undoes its smoothing (an OE g is already smoothed).
    """
    chain = Chain(spec, theta)
    sl = spec.slices()
    assert chain.g is not None  # process noise enters at g's input: every noise spec has g
    gx = chain.g[0]
    cols, rhs = [], []
    for u, y in zip(us, ys):
        basis = blocks.pwl_expected(gx, np.zeros(len(gx)), chain.linear_sum(u), chain.g_sigma, derivatives=True)[3]
        if chain.h2 is not None:
            b, den, _ = chain.h2
            basis = block_filter(b, den, basis)
        cols.append(np.hstack([basis, np.ones((len(u), 1))])[skip:])
        rhs.append(y[skip:])
    sol = lstsq(np.vstack(cols), np.concatenate(rhs))
    out = np.array(theta, dtype=float)
    if np.all(np.isfinite(sol)):
        out[sl["g.y"]], out[sl["offset"]] = sol[:-1], sol[-1]
    return out


def with_process_noise(fit: Fit, us, ys, opts: Options, starts=NOISE_STARTS, alternatives=()) -> Fit:
    """Refine ``fit`` (a model with a map g) with a Gaussian process noise at g's input.

    The parameters gain log(sigma) and the cost becomes the error of the expected output
    y = H2(E_v g(H1 u + v)), so g is learnt as the noise-free map instead of the noise-smoothed
    one an output-error fit returns. Each starting sigma (``starts`` x the standard deviation
    of g's input under ``fit``) gets g by least squares (:func:`_noise_start`); the starts are
    screened briefly and the best one is refined. The result's error is never above ``fit``'s:
    when no sigma helps, ``fit`` itself comes back with a vanishing sigma.

    When recordings repeat their input, the noise level comes from the differences between
    periods instead (:func:`noise_from_periods`), and every build in ``alternatives`` (other
    output-error fits of the same orders) is refined too, on the machine's cores
    (:func:`map_builds`); they are chosen between by the order search's rule
    (the fewest parameters within the noise, :func:`within_noise`), and the one chosen is kept
    only when the records determine its noise-free system (:func:`deconvolution_spread`). Each
    build's notes also say whether white noise at g's input explains the colour of the period
    differences (:mod:`noise_colour`), a diagnostic.
    """
    if not fit.spec.g_bp or fit.spec.g_noise:
        raise ValueError("process noise needs a map g and a model without it")
    periods = noise_level.PeriodData(us, ys, opts.skip)
    if periods:
        builds = [fit] + [f for f in alternatives if f.spec.g_bp and not f.spec.g_noise]
        n = sum(len(y) - opts.skip for y in ys)
        refined = map_builds(partial(noise_from_periods, us=us, ys=ys, opts=opts, periods=periods), builds)
        parents = {id(f): b for f, b in zip(refined, builds)}
        consistent = [f for f in refined if f.notes["process_noise"]["consistent"]]
        if consistent:
            tied = within_noise(consistent, n)
            chosen = min(tied, key=lambda f: (f.spec.n_params, f.sse))
            spread = deconvolution_spread(chosen, parents[id(chosen)], tied, us, opts.skip)
            chosen.notes["process_noise"]["deconvolution"] = spread
            if spread["determined"]:
                return chosen
            # Builds the data cannot tell apart disagree on the noise-free system by more than
            # the chosen one moved away from its output-error fit: the deconvolution is not
            # determined by these records, and the output-error fit (the smoothed map) stays.
            out = _vanishing_noise(fit, us, ys, opts.skip)
            out.build = (fit.build + " + " if fit.build else "") + "process noise undetermined"
            out.notes = {"process_noise": {**chosen.notes["process_noise"], "method": "repeated periods, undetermined"}}
            return out
        # No build reproduces the measured period power at any level tried: its noise model is
        # refuted by the data, and the output-error fit stays (as a vanishing noise).
        closest = min(refined, key=lambda f: abs(np.log(f.notes["process_noise"]["power_ratio"])))
        out = _vanishing_noise(fit, us, ys, opts.skip)
        out.build = (fit.build + " + " if fit.build else "") + "process noise rejected"
        out.notes = {"process_noise": {**closest.notes["process_noise"], "method": "repeated periods, rejected"}}
        return out
    spec = replace(fit.spec, g_noise=True)
    sl, old = spec.slices(), fit.spec.slices()
    chain = Chain(fit.spec, fit.theta)
    g_input_std = float(np.std(np.concatenate([chain.linear_sum(u)[opts.skip :] for u in us]))) or 1.0
    thetas = []
    with np.errstate(all="ignore"):
        for frac in starts:
            theta = np.zeros(spec.n_params)
            cut = old["g.y"].stop
            theta[:cut] = fit.theta[:cut]
            theta[sl["g.s"]] = np.log(frac * g_input_std)
            theta[sl["g.s"].stop :] = fit.theta[cut:]
            thetas.append(_noise_start(spec, theta, us, ys, opts.skip))
        costs = [sse(spec, t, us, ys, opts.skip) for t in thetas]
        keep = [thetas[i] for i in np.argsort(costs)[: max(opts.starts, 1)]]
        out = multistart(spec, keep, us, ys, opts)
        if not out.sse <= fit.sse:
            # No noise level beats the output-error fit: keep it, as a vanishing noise.
            out = _vanishing_noise(fit, us, ys, opts.skip, out.nfev)
    out.build = (fit.build + " + " if fit.build else "") + "process noise"
    return out


def _vanishing_noise(fit: Fit, us, ys, skip: int, nfev: int = 0) -> Fit:
    """``fit`` as a process-noise model whose noise vanishes (sigma = exp(-30)): the same output."""
    spec = replace(fit.spec, g_noise=True)
    sl, cut = spec.slices(), fit.spec.slices()["g.y"].stop
    theta = np.zeros(spec.n_params)
    theta[:cut] = fit.theta[:cut]
    theta[sl["g.s"]] = -30.0
    theta[sl["g.s"].stop :] = fit.theta[cut:]
    return Fit(spec, theta, sse(spec, theta, us, ys, skip), nfev)


# The smallest weight of the smoothness grid (search.choose_smoothness). A noise-aware g is a
# deconvolution of the noise-smoothed map: without a penalty its values between what the
# smoothed data pin down are unbounded (they explode by orders of magnitude on the measured
# WH benchmark).
NOISE_MIN_SMOOTHNESS = 1e-4
# Noise levels bracketed first, as fractions of the spread of g's input under the OE fit.
PERIOD_LEVELS = (0.25, 0.5, 1.0, 2.0, 4.0)
PERIOD_STEPS = 4  # refined models at most per build
PERIOD_TOLERANCE = 0.05  # |log power ratio| accepted: 5 %, below the Monte Carlo scatter of the check


def at_noise_level(fit: Fit, spec: ChainSpec, us, ys, sigma: float, opts: Options, refine_blocks: bool) -> Fit:
    """The model of ``fit`` with its noise held at ``sigma``: g's breakpoints over the quantiles
    of g's input plus that noise, g's values and the offset by penalised least squares, then
    (``refine_blocks``) every parameter but sigma refined on the expected output."""
    chain = Chain(fit.spec, fit.theta)
    sl, old = spec.slices(), fit.spec.slices()
    xs = [chain.linear_sum(u) for u in us]
    rng = np.random.default_rng(0)
    pooled = np.concatenate([x[opts.skip :] for x in xs])
    gx = blocks.initial_breakpoints(pooled + sigma * rng.standard_normal(len(pooled)), spec.g_bp)
    theta = np.zeros(spec.n_params)
    for name in sl:
        if name in old and not name.startswith("g."):
            theta[sl[name]] = fit.theta[old[name]]
    theta[sl["g.p"]] = blocks.positions_to_p(gx)
    theta[sl["g.s"]] = np.log(sigma)
    cols, rhs = [], []
    for x, y in zip(xs, ys):
        basis = blocks.pwl_expected(gx, np.zeros(len(gx)), x, sigma, derivatives=True)[3]
        if chain.h2 is not None:
            b, den, _ = chain.h2
            basis = block_filter(b, den, basis)
        cols.append(np.hstack([basis, np.ones((len(x), 1))])[opts.skip :])
        rhs.append(y[opts.skip :])
    phi, r = np.vstack(cols), np.concatenate(rhs)
    d2 = np.diff(np.eye(len(gx)), 2, axis=0) * np.sqrt(opts.smoothness * len(r))
    phi = np.vstack([phi, np.hstack([d2, np.zeros((len(d2), 1))])])
    sol = lstsq(phi, np.concatenate([r, np.zeros(len(d2))]))
    if np.all(np.isfinite(sol)):
        theta[sl["g.y"]], theta[sl["offset"]] = sol[:-1], sol[-1]
    if refine_blocks:
        # sigma is held, and so is the spread of g's input: scaling H1 by k and stretching g by
        # k leaves the noise-free model as it is but makes a held sigma a noise k times smaller
        # relative to g's input, and the expected-output cost alone would drift along that path.
        n_res = sum(len(y) - opts.skip for y in ys)
        spread = _SpreadConstraint(spec, us, opts.skip, float(np.std(pooled)), n_res)
        return refine(spec, theta, us, ys, replace(opts, frozen=(sl["g.s"].start,), constraint=spread))
    return Fit(spec, theta, sse(spec, theta, us, ys, opts.skip))


class _SpreadConstraint:
    """A stiff residual holding the standard deviation of g's input at ``target``: weight 100 x
    sqrt(samples) on its log, so a 1 % change costs as much as the whole simulation error.

    Its Jacobian is analytic: with s = g's input and J_k = ds/dtheta_k (the sensitivities of the
    linear branches, only they move s), d log std(s) / dtheta_k = cov(s, J_k) / var(s)."""

    def __init__(self, spec: ChainSpec, us, skip: int, target: float, n_res: int):
        self.spec, self.us, self.skip = spec, us, skip
        self.log_target = np.log(target)
        self.weight = 100.0 * np.sqrt(n_res)
        self.upstream = np.arange(spec.slices()["g.p"].start)  # the parameters before g
        # The branches alone (f, H1, delay) with an offset: their parameters come first in both.
        self.branches = ChainSpec(spec.n_inputs, spec.np1, spec.nz1, f_bp=spec.f_bp, delay=spec.delay)

    def _log_spread(self, theta) -> float:
        chain = Chain(self.spec, theta)
        return float(np.log(np.std(np.concatenate([chain.linear_sum(u)[self.skip :] for u in self.us]))))

    def residual(self, theta) -> np.ndarray:
        return np.array([self.weight * (self._log_spread(theta) - self.log_target)])

    def jacobian(self, theta) -> np.ndarray:
        chain = Chain(self.branches, np.concatenate([np.asarray(theta)[self.upstream], [0.0]]))
        parts = [chain.jacobian_rows(u) for u in self.us]
        s = np.concatenate([y[self.skip :] for y, _ in parts])
        rows = np.hstack([jt[: len(self.upstream), self.skip :] for _, jt in parts])
        ds = s - s.mean()
        grad = (rows @ ds / len(s) - rows.mean(axis=1) * ds.mean()) / float(ds @ ds / len(s))
        jac = np.zeros((1, self.spec.n_params))
        jac[0, self.upstream] = grad
        return self.weight * jac

    def __call__(self, theta):
        return self.residual(theta), self.jacobian(theta)


def noise_from_periods(fit: Fit, us, ys, opts: Options, periods) -> Fit:
    """Process noise whose level comes from the repeated periods (:mod:`noise_level`).

    The level is bracketed on models whose g alone is re-solved for it (fast), where the
    simulated period differences cross the measured power; then up to PERIOD_STEPS Newton
    steps on log(sigma) refine the whole model at a level and check its own ratio, until it is
    within PERIOD_TOLERANCE. The expected-output cost decides every other parameter.
    """
    spec = replace(fit.spec, g_noise=True)
    opts = replace(opts, smoothness=max(opts.smoothness, NOISE_MIN_SMOOTHNESS))
    chain = Chain(fit.spec, fit.theta)
    spread = float(np.std(np.concatenate([chain.linear_sum(u)[opts.skip :] for u in us]))) or 1.0
    levels, logs = [], []
    for frac in PERIOD_LEVELS:
        sigma = frac * spread
        trial = at_noise_level(fit, spec, us, ys, sigma, opts, refine_blocks=False)
        levels.append(sigma)
        logs.append(np.log(periods.evaluate(spec, trial.theta, us, sigma).power_ratio))
        if logs[-1] > 0:
            break
    sigma = _crossing(levels, logs)
    # Newton steps on log(sigma) through the refined models' own ratios; the slope from the
    # bracket until two refined models give their own.
    slope = _slope(levels, logs)
    tried = []
    for _ in range(PERIOD_STEPS):
        out = at_noise_level(fit, spec, us, ys, sigma, opts, refine_blocks=True)
        check = periods.evaluate(spec, out.theta, us, sigma)
        if not (np.isfinite(check.power_ratio) and check.power_ratio > 0):
            break
        tried.append((abs(np.log(check.power_ratio)), sigma, out, check))
        if abs(np.log(check.power_ratio)) < PERIOD_TOLERANCE:
            break
        if len(tried) >= 2:
            slope = _slope([t[1] for t in tried[-2:]], [np.log(t[3].power_ratio) for t in tried[-2:]]) or slope
        sigma = float(sigma * np.exp(-np.clip(np.log(check.power_ratio) / slope, -1.0, 1.0)))
    if not tried:
        raise ValueError("the period differences could not be simulated")
    _, sigma, out, check = min(tried, key=lambda t: t[0])
    out.build = (fit.build + " + " if fit.build else "") + "process noise (level from repeated periods)"
    out.notes = {
        "process_noise": {
            "method": "repeated periods",
            "periods": periods.describe(),
            "sigma": float(sigma),
            "sigma_per_spread": float(sigma / spread),
            "power_ratio": float(check.power_ratio),
            "power_ratio_error": float(check.ratio_error),
            "consistent": periods.consistent(check, PERIOD_TOLERANCE),
            "colour": _colour_or_none(periods, spec, out.theta, us),
            "shape_misfit": float(check.shape_misfit),
            "band_edges": check.band_edges.tolist(),
            "noise_density": check.shape.tolist(),
            "smoothness": opts.smoothness,
        }
    }
    return out


def _colour_or_none(periods, spec: ChainSpec, theta, us) -> dict | None:
    """The period-difference colour diagnostic (:mod:`noise_colour`) as a dict, or None when
    the differences hold too few Welch segments to test it (the fit stands either way)."""
    try:
        return noise_colour.check(periods, spec, theta, us).to_dict()
    except ValueError:
        return None


def map_builds(refine_build, builds: list) -> list:
    """``refine_build`` applied to every build, in order. The builds are independent, so in the
    main process they run on a pool of the machine's cores (whose workers ignore Ctrl-C: an
    interrupt terminates them, :func:`porosense.ident.workers.stop`); inside a worker (the order
    search already spreads its candidates over the cores) they run one after another."""
    workers = min(os.cpu_count() or 1, len(builds))
    if workers < 2 or multiprocessing.parent_process() is not None:
        return [refine_build(f) for f in builds]
    try:
        pool = local_pool(workers)
    except OSError:  # no processes to be had here: the same work in turn
        return [refine_build(f) for f in builds]
    finished = False
    try:
        out = list(pool.map(refine_build, builds))
        finished = True
        return out
    except (OSError, BrokenProcessPool):
        return [refine_build(f) for f in builds]
    finally:
        if finished:
            pool.shutdown()
        else:
            stop(pool)


def within_noise(fits: list[Fit], n: int) -> list[Fit]:
    """The fits whose error is within one standard error of the lowest, the tie of the order
    search's rule (search.SearchResult), with the same standard error
    (metrics.relative_standard_error; twice it for a squared error). Noise-aware builds differ
    in how they split the dynamics between H1 and H2; on the measured benchmark their expected
    outputs agree to 0.2-0.7 % against a standard error of 0.5-0.7 %
    (``porosense bench ident --only builds``)."""
    finite = [f for f in fits if np.isfinite(f.sse)]
    if not finite:
        return fits[:1]
    low = min(f.sse for f in finite)
    return [f for f in finite if f.sse <= low * (1.0 + 2.0 * relative_standard_error(n))]


def deconvolution_spread(chosen: Fit, parent: Fit, tied: list[Fit], us, skip: int) -> dict:
    """Whether the records determine the noise-free system a process-noise fit deconvolves.

    ``tied`` are the noise-aware builds the records cannot tell apart (their expected outputs
    agree within one standard error), ``chosen`` one of them and ``parent`` the output-error
    fit it was refined from. On the estimation inputs (normalised output units, RMS past
    ``skip``): ``correction`` is how far the chosen noise-free output moved from its parent's,
    ``spread`` the largest distance from it to another tied build's noise-free output.
    Determined when the correction exceeds the spread by more than one relative standard error
    of an RMS norm over those samples: the output-error fit then lies farther
    from the chosen model than every model the data support as well, so the correction is not
    one of the ambiguities the records leave open. (A rank statement over the tied builds, not a
    significance level: with K tied builds, an output-error fit that were just one more of them
    would lie farthest with probability 1 / K.)"""

    def noise_free(f):
        chain = Chain(f.spec, f.theta)
        return np.concatenate([chain.simulate(u, expected=False)[skip:] for u in us])

    base = noise_free(chosen)
    rms = lambda d: float(np.sqrt(np.mean(d**2)))
    correction = rms(base - noise_free(parent))
    spread = max([rms(noise_free(f) - base) for f in tied if f is not chosen] or [0.0])
    # Both are RMS norms over the same samples, each known to one relative standard error
    # (metrics.relative_standard_error): a tied build that sits on the output-error fit (the two
    # distances equal within it) leaves the correction undetermined, whichever is larger by
    # rounding (measured on the independent generator, seed 5: 0.2210 against 0.2206).
    margin = relative_standard_error(len(base))
    return {
        "correction": correction,
        "spread": spread,
        "margin": margin,
        "tied_builds": len(tied),
        "determined": bool(correction > spread * (1.0 + margin)),
    }


def _slope(levels, logs) -> float:
    """d log(power ratio) / d log(sigma) by least squares over the finite points (>= 0.5;
    2 for a linear g: the output noise power grows with sigma squared)."""
    lv, lr = np.log(np.asarray(levels, dtype=float)), np.asarray(logs, dtype=float)
    ok = np.isfinite(lr)
    if np.sum(ok) < 2 or np.ptp(lv[ok]) == 0:
        return 2.0
    return float(max(np.polyfit(lv[ok], lr[ok], 1)[0], 0.5))


def _crossing(levels, logs) -> float:
    """Level where the log power ratio, linear in log level between neighbours, first crosses
    0 upwards; the nearest level tried when it never crosses."""
    lv = np.log(np.asarray(levels, dtype=float))
    lr = np.asarray(logs, dtype=float)
    ok = np.isfinite(lr)
    if not np.any(ok):
        raise ValueError("no noise level gave a finite period-difference power")
    order = np.argsort(lv[ok])
    lv, lr = lv[ok][order], lr[ok][order]
    for k in range(len(lv) - 1):
        if lr[k] <= 0 < lr[k + 1]:
            t = lr[k] / (lr[k] - lr[k + 1])
            return float(np.exp(lv[k] + t * (lv[k + 1] - lv[k])))
    return float(np.exp(lv[np.argmin(np.abs(lr))]))
