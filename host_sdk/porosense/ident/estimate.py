"""Simulation-error estimation of every structure, with the starting points of the paper.

All functions work on normalised data: ``us`` a list of (N_r, n_inputs) arrays, ``ys`` a list
of (N_r,) arrays, one pair per recording (each simulated from rest). They return a
:class:`Fit` holding the :class:`ChainSpec`, the parameters and the sum of squared errors.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
from scipy.optimize import least_squares

from porosense.ident import bla_split, blocks, noise_colour, noise_level
from porosense.ident.chain import Chain, ChainSpec, _filter
from porosense.ident.linear_init import arx, iv
from porosense.ident.lm import levenberg_marquardt
from porosense.ident.metrics import relative_standard_error


def lstsq(phi, rhs):
    """Least squares for tall ``phi`` through its (small) normal equations, ridge-guarded."""
    gram = phi.T @ phi
    ridge = 1e-10 * np.trace(gram) / max(len(gram), 1)
    try:
        return np.linalg.solve(gram + ridge * np.eye(len(gram)), phi.T @ rhs)
    except np.linalg.LinAlgError:
        return np.full(phi.shape[1], np.nan)


@dataclass
class Fit:
    spec: ChainSpec
    theta: np.ndarray
    sse: float
    nfev: int = 0
    build: str = ""
    notes: dict = field(default_factory=dict)  # how a part of the fit was decided (process noise)


@dataclass(frozen=True)
class Options:
    """Optimiser settings: evaluations per refinement, tolerance, samples skipped per record."""

    max_nfev: int = 200
    tol: float = 1e-7
    skip: int = 0
    starts: int = 2
    smoothness: float = 0.0
    monotone: bool = False
    frozen: tuple = ()  # indices of parameters held at their starting values
    constraint: object = None  # theta -> (extra residuals, their Jacobian rows), or None


def sse(spec, theta, us, ys, skip=0) -> float:
    chain = Chain(spec, theta)
    return float(sum(np.sum((chain.simulate(u)[skip:] - y[skip:]) ** 2) for u, y in zip(us, ys)))


def _penalty_rows(spec: ChainSpec, theta, n_res: int, opts: Options):
    """Extra residuals and their Jacobian rows regularising the piecewise-linear values.

    Smoothness: sqrt(smoothness * n_res) times the second differences of every map's values
    (normalised units, so the weight is dimensionless: the penalty is smoothness x the mean
    squared error of a model whose maps bend by one output standard deviation per breakpoint).
    Monotone: a stiff penalty (weight n_res) on every step against the direction of the map's
    first-to-last change, so the refined maps come out monotone up to rounding.
    """
    rows, jac = [], []
    sl = spec.slices()
    names = [n for n in sl if n.endswith(".y")]
    for name in names:
        idx = np.arange(sl[name].start, sl[name].stop)
        v = theta[idx]
        if opts.smoothness > 0 and len(v) >= 3:
            w = np.sqrt(opts.smoothness * n_res)
            d2 = np.zeros((len(v) - 2, spec.n_params))
            for k in range(len(v) - 2):
                d2[k, idx[k : k + 3]] = w * np.array([1.0, -2.0, 1.0])
            rows.append(d2 @ theta)
            jac.append(d2)
        if opts.monotone and len(v) >= 2:
            sign = 1.0 if v[-1] >= v[0] else -1.0
            w = np.sqrt(float(n_res))
            step = np.diff(v) * sign
            active = step < 0
            m = np.zeros((len(v) - 1, spec.n_params))
            for k in np.flatnonzero(active):
                m[k, idx[k]], m[k, idx[k + 1]] = -w * sign, w * sign
            rows.append(np.where(active, w * step, 0.0))
            jac.append(m)
    if not rows:
        return None, None
    return np.concatenate(rows), np.vstack(jac)


def refine(spec: ChainSpec, theta0, us, ys, opts: Options) -> Fit:
    """Minimise the simulation error over all recordings (LM with the exact J, :mod:`lm`),
    plus the optional smoothness / monotone penalties of :func:`_penalty_rows`."""
    skip = opts.skip
    n_sim = sum(len(y) - skip for y in ys)
    regular = (opts.smoothness > 0 or opts.monotone) and (spec.f_bp or spec.g_bp)

    def residuals(theta):
        chain = Chain(spec, theta)
        r = np.concatenate([chain.simulate(u)[skip:] - y[skip:] for u, y in zip(us, ys)])
        if regular:
            extra, _ = _penalty_rows(spec, theta, n_sim, opts)
            r = np.concatenate([r, extra])
        if opts.constraint is not None:
            r = np.concatenate([r, opts.constraint(theta)[0]])
        return np.where(np.isfinite(r), r, 1e6)

    def jacobian(theta):
        chain = Chain(spec, theta)
        j = np.vstack([chain.jacobian(u)[1][skip:] for u in us])
        if regular:
            j = np.vstack([j, _penalty_rows(spec, theta, n_sim, opts)[1]])
        if opts.constraint is not None:
            j = np.vstack([j, opts.constraint(theta)[1]])
        if opts.frozen:  # a zero column: no step ever moves it
            j[:, list(opts.frozen)] = 0.0
        return np.where(np.isfinite(j), j, 0.0)

    theta0 = np.asarray(theta0, dtype=float)
    start_sse = float(np.sum(residuals(theta0) ** 2))
    n_res = sum(len(y) - skip for y in ys)
    method = "lm" if n_res >= spec.n_params else "trf"
    try:
        if method == "lm":  # tall problem: LM on the normal equations (lm.py says why)
            res = levenberg_marquardt(
                residuals, jacobian, theta0, max_nfev=opts.max_nfev, ftol=opts.tol, xtol=opts.tol, gtol=opts.tol
            )
            theta, cost, nfev = res.x, res.cost, res.nfev
        else:
            res = least_squares(
                residuals,
                theta0,
                jac=jacobian,
                method=method,
                max_nfev=opts.max_nfev,
                ftol=opts.tol,
                xtol=opts.tol,
                gtol=opts.tol,
                x_scale=1.0,
            )
            theta, cost, nfev = res.x, 2.0 * res.cost, res.nfev
    except (np.linalg.LinAlgError, ValueError):
        theta, cost, nfev = theta0, start_sse, 0
    if not cost <= start_sse:
        theta, cost = theta0, start_sse
    if regular or opts.constraint is not None:  # report the simulation error alone
        cost = sse(spec, theta, us, ys, skip)
    return Fit(spec, theta, float(cost), int(nfev))


# ----------------------------------------------------------------------------- linear


def _linear_theta(spec: ChainSpec, a_list, b_list, offset) -> np.ndarray:
    theta = np.zeros(spec.n_params)
    sl = spec.slices()
    for i in range(spec.n_inputs):
        a = np.asarray(a_list[i], dtype=float)
        theta[sl[f"h1{i}.a"]] = blocks.theta_from_poly(a, spec.np1)
        b = np.zeros(spec.nz1 + 1)
        bi = np.asarray(b_list[i], dtype=float)[: spec.nz1 + 1]
        b[: len(bi)] = bi
        theta[sl[f"h1{i}.b"]] = b
    theta[sl["offset"]] = offset
    return theta


def fit_linear(us, ys, n_poles, n_zeros, delay, opts: Options) -> Fit:
    """Output-error MISO model, each input its own B_i/F_i; started from the better of ARX/IV."""
    spec = ChainSpec(us[0].shape[1], n_poles, n_zeros, delay=delay)
    best = None
    for method in (arx, iv):
        a, bs, c = method(us, ys, n_poles, n_zeros, delay)
        # Offset c enters through 1/A: its steady-state value is c / A(1).
        a_sum = float(np.sum(a))
        offset = c / a_sum if abs(a_sum) > 1e-6 else float(np.mean(np.concatenate(ys)))
        theta = _linear_theta(spec, [a] * spec.n_inputs, bs, offset)
        cost = sse(spec, theta, us, ys, opts.skip)
        if best is None or cost < best[1]:
            best = (theta, cost)
    return refine(spec, best[0], us, ys, opts)


# ------------------------------------------------------------------------- nonlinear


def _hat_basis(x, u):
    """Columns of the PWL map through x with unit value at one breakpoint (N, len(x))."""
    return blocks.pwl_eval(x, np.zeros(len(x)), u, derivatives=True)[3]


def _hammerstein_starts(lin: Fit, us, ys, n_bp, delay, opts):
    """Two starts: f by least squares through the BLA's H1, and f = identity."""
    n_in = us[0].shape[1]
    spec = ChainSpec(n_in, lin.spec.np1, lin.spec.nz1, f_bp=n_bp, delay=delay)
    lchain = Chain(lin.spec, lin.theta)
    xs = [blocks.initial_breakpoints(np.concatenate([u[:, i] for u in us]), n_bp) for i in range(n_in)]
    sl, lsl = spec.slices(), lin.spec.slices()

    def theta_with(fys, offset):
        theta = np.zeros(spec.n_params)
        for i in range(n_in):
            theta[sl[f"f{i}.p"]] = blocks.positions_to_p(xs[i])
            theta[sl[f"f{i}.y"]] = fys[i]
            theta[sl[f"h1{i}.a"]] = lin.theta[lsl[f"h1{i}.a"]]
            theta[sl[f"h1{i}.b"]] = lin.theta[lsl[f"h1{i}.b"]]
        theta[sl["offset"]] = offset
        return theta

    # The identity f (equal to the linear model) is always a start; others are added to it.
    starts = [theta_with(xs, lchain.offset)]
    # Least squares for the f values with the BLA's dynamics held: y - c = sum H1_i(hat(u_i)) fy_i.
    cols = []
    for u in us:
        xin = lchain.branch_inputs(u)
        blocks_i = []
        for i in range(n_in):
            b, den, _ = lchain.h1[i]
            blocks_i.append(_filter(b, den, _hat_basis(xs[i], xin[i])))
        cols.append(np.hstack(blocks_i + [np.ones((len(u), 1))]))
    phi = np.vstack(cols)
    sol = lstsq(phi, np.concatenate(ys))
    if np.all(np.isfinite(sol)):
        fys = [sol[i * n_bp : (i + 1) * n_bp] for i in range(n_in)]
        starts.append(theta_with(fys, sol[-1]))
    return spec, starts[: max(opts.starts, 1)]


def _bla_options(opts: Options) -> Options:
    """The linear model a nonlinear one starts from: the best linear model of its order (fully
    refined), so that the nonlinear model's first iterate already equals the linear fit."""
    return Options(max_nfev=opts.max_nfev, tol=opts.tol, skip=opts.skip, starts=1)


def fit_hammerstein(us, ys, n_poles, n_zeros, n_bp, delay, opts: Options, lin: Fit | None = None) -> Fit:
    """f_i then B_i/F_i; best of the multi-start refinements from the best linear approximation."""
    lin = lin or fit_linear(us, ys, n_poles, n_zeros, delay, _bla_options(opts))
    spec, starts = _hammerstein_starts(lin, us, ys, n_bp, delay, opts)
    return multistart(spec, starts, us, ys, opts)


def _wiener_starts(lin: Fit, us, ys, n_bp, delay, opts):
    n_in = us[0].shape[1]
    spec = ChainSpec(n_in, lin.spec.np1, lin.spec.nz1, g_bp=n_bp, delay=delay)
    lchain = Chain(lin.spec, lin.theta)
    ss = [lchain.linear_sum(u) for u in us]
    x = blocks.initial_breakpoints(np.concatenate(ss), n_bp)
    sl = spec.slices()
    base = np.zeros(spec.n_params)
    base[: sl["g.p"].start] = lin.theta[: sl["g.p"].start]
    base[sl["g.p"]] = blocks.positions_to_p(x)
    # The identity g (equal to the linear model) is always a start; others are added to it.
    t = base.copy()
    t[sl["g.y"]] = x
    t[sl["offset"]] = lchain.offset
    starts = [t]
    phi = np.vstack([_hat_basis(x, s) for s in ss])
    gy = lstsq(phi, np.concatenate(ys))
    if np.all(np.isfinite(gy)):
        t = base.copy()
        t[sl["g.y"]] = gy
        starts.append(t)
    return spec, starts[: max(opts.starts, 1)]


def fit_wiener(us, ys, n_poles, n_zeros, n_bp, delay, opts: Options, lin: Fit | None = None) -> Fit:
    """B_i/F_i summed, then g; multi-start from the best linear approximation."""
    lin = lin or fit_linear(us, ys, n_poles, n_zeros, delay, _bla_options(opts))
    spec, starts = _wiener_starts(lin, us, ys, n_bp, delay, opts)
    return multistart(spec, starts, us, ys, opts)


# ------------------------------------------------------------------ Wiener-Hammerstein
#
# Order convention: WH(p, z) has one linear block of p poles and z zeros and one first-order
# section (1 pole, 1 zero). Built "Wiener + linear", H1 carries (p, z) and H2 is the
# first-order section; built "linear + Hammerstein", H2 carries (p, z) and H1 is the
# first-order section (SISO), or, for several inputs, each branch keeps the Hammerstein's
# f_i -> H1_i (p, z) and g plus the first-order H2 follow the sum. Started at identity, the
# extra section and g leave the Wiener / Hammerstein model of the same order unchanged, so
# the WH class contains both and its estimate is never worse than either start.

IDENTITY_SECTION_B = (1.0, 0.0)  # b0 + b1 q^-1 of the first-order section at identity (a1 = 0)


def _identity_section():
    """(a parameters, b) of a first-order section equal to the identity: a1 = 0, b = [1, 0]."""
    return np.zeros(1), np.array(IDENTITY_SECTION_B)


def wiener_plus_linear(wien: Fit) -> tuple[ChainSpec, np.ndarray]:
    """The WH start equal to the Wiener model ``wien``: H1 (p, z) -> g -> H2 = identity."""
    ws = wien.spec
    spec = ChainSpec(ws.n_inputs, ws.np1, ws.nz1, g_bp=ws.g_bp, h2=True, np2=1, nz2=1, delay=ws.delay)
    sl, wsl = spec.slices(), ws.slices()
    theta = np.zeros(spec.n_params)
    theta[: wsl["offset"].start] = wien.theta[: wsl["offset"].start]
    theta[sl["h2.a"]], theta[sl["h2.b"]] = _identity_section()
    theta[sl["offset"]] = wien.theta[wsl["offset"]]
    return spec, theta


def linear_plus_hammerstein(ham: Fit, us, n_bp: int) -> tuple[ChainSpec, np.ndarray]:
    """The WH start equal to the Hammerstein model ``ham``.

    One input: H1 = identity section -> g = f -> H2 = the Hammerstein's (p, z) block.
    Several inputs: f_i -> H1_i (p, z) kept per branch, then g = identity over the range of
    the sum (exact: linear beyond its ends) and H2 = identity section.
    """
    hs = ham.spec
    hsl = hs.slices()
    theta_h = ham.theta
    if hs.n_inputs == 1:
        spec = ChainSpec(1, 1, 1, g_bp=hs.f_bp, h2=True, np2=hs.np1, nz2=hs.nz1, delay=hs.delay)
        sl = spec.slices()
        theta = np.zeros(spec.n_params)
        theta[sl["h10.a"]], theta[sl["h10.b"]] = _identity_section()
        theta[sl["g.p"]] = theta_h[hsl["f0.p"]]
        theta[sl["g.y"]] = theta_h[hsl["f0.y"]]
        theta[sl["h2.a"]] = theta_h[hsl["h10.a"]]
        theta[sl["h2.b"]] = theta_h[hsl["h10.b"]]
        theta[sl["offset"]] = theta_h[hsl["offset"]]
        return spec, theta
    spec = ChainSpec(hs.n_inputs, hs.np1, hs.nz1, f_bp=hs.f_bp, g_bp=n_bp, h2=True, np2=1, nz2=1, delay=hs.delay)
    sl = spec.slices()
    theta = np.zeros(spec.n_params)
    theta[: hsl["offset"].start] = theta_h[: hsl["offset"].start]
    hchain = Chain(hs, theta_h)
    x = blocks.initial_breakpoints(np.concatenate([hchain.linear_sum(u) for u in us]), n_bp)
    theta[sl["g.p"]] = blocks.positions_to_p(x)
    theta[sl["g.y"]] = x
    theta[sl["h2.a"]], theta[sl["h2.b"]] = _identity_section()
    theta[sl["offset"]] = theta_h[hsl["offset"]]
    return spec, theta


def fit_wh(
    us, ys, n_poles, n_zeros, n_bp, delay, opts: Options, wiener: Fit | None = None, hammerstein: Fit | None = None
) -> Fit:
    """H1, g, H2 built both ways (Wiener + linear, linear + Hammerstein), each refined jointly.

    ``wiener`` / ``hammerstein``: the Wiener and Hammerstein fits of the same order on the same
    (normalised) data when already at hand (the order search reuses them); otherwise they are
    estimated here from one shared best linear approximation. Each build starts exactly at its
    model (same simulation error) and the refinement never returns a higher cost, so the
    result's error is at most min(Wiener, Hammerstein). ``Fit.build`` names the winner.
    """
    return wh_fits(us, ys, n_poles, n_zeros, n_bp, delay, opts, wiener, hammerstein)[0]


def wh_fits(
    us,
    ys,
    n_poles,
    n_zeros,
    n_bp,
    delay,
    opts: Options,
    wiener: Fit | None = None,
    hammerstein: Fit | None = None,
    linear: Fit | None = None,
) -> list[Fit]:
    """As :func:`fit_wh`, but every member: the best refinement first, then the other
    refinements and the starting models (``build`` ends in " start").

    With one input and at least 2 poles, a third build starts from the best linear model of
    the order with its poles and zeros split between H1 and H2 (:mod:`bla_split`): both blocks
    at full order, g the identity on the quantiles of H1's output, so the start equals the
    linear model; the best-scoring split (g by least squares) is refined jointly.
    """
    lin = linear
    if lin is None and (wiener is None or hammerstein is None or us[0].shape[1] == 1):
        lin = fit_linear(us, ys, n_poles, n_zeros, delay, _bla_options(opts))
    if wiener is None or hammerstein is None:
        wiener = wiener or fit_wiener(us, ys, n_poles, n_zeros, n_bp, delay, opts, lin=lin)
        hammerstein = hammerstein or fit_hammerstein(us, ys, n_poles, n_zeros, n_bp, delay, opts, lin=lin)
    fits, starts = [], []
    for build, (spec, theta0), parent in (
        ("wiener+linear", wiener_plus_linear(wiener), wiener),
        ("linear+hammerstein", linear_plus_hammerstein(hammerstein, us, n_bp), hammerstein),
    ):
        start = sse(spec, theta0, us, ys, opts.skip)
        # The start is the parent model itself; only rounding may separate the two errors.
        if not start <= parent.sse * (1 + 1e-9) + 1e-12:
            raise ArithmeticError(f"WH start {build}: error {start} above its model's {parent.sse}")
        fit = refine(spec, theta0, us, ys, opts)
        if not fit.sse <= start:  # a failed (or rounding-only) refinement: keep the start
            fit = Fit(spec, theta0, start, fit.nfev)
        fit.build = build
        fits.append(fit)
        starts.append(Fit(spec, theta0, start, 0, build + " start"))
    if lin is not None:
        split_fits, split_starts = _split_builds(lin, us, ys, n_bp, opts)
        fits += split_fits
        starts += split_starts
    fits.sort(key=lambda f: f.sse if np.isfinite(f.sse) else np.inf)
    return fits + starts


def _split_builds(lin: Fit, us, ys, n_bp, opts: Options):
    """Refinements of the best BLA pole/zero splits, and the split start equal to the linear model."""
    # The best-scored split only: the two routes are the other starts (cost of the paper's grid).
    ranked = bla_split.ranked_split_starts(lin.spec, lin.theta, us, ys, n_bp, opts.skip, keep=1)
    fits, starts = [], []
    for k, (_, spec, theta_ls, theta_identity, split) in enumerate(ranked):
        fit = refine(spec, theta_ls, us, ys, opts)
        fit.build = f"bla split ({split.describe()})"
        fits.append(fit)
        if k == 0:
            start = sse(spec, theta_identity, us, ys, opts.skip)
            starts.append(Fit(spec, theta_identity, start, 0, "bla split start"))
    return fits, starts


def multistart(spec: ChainSpec, starts, us, ys, opts: Options) -> Fit:
    """Refine every start briefly, then continue the best one with the remaining budget."""
    if len(starts) == 1:
        return refine(spec, starts[0], us, ys, opts)
    screen = max(opts.max_nfev // 10, 8)
    short = replace(opts, max_nfev=screen, tol=max(opts.tol, 1e-5))
    best = _best([refine(spec, t, us, ys, short) for t in starts])
    rest = replace(opts, max_nfev=max(opts.max_nfev - screen, 1))
    final = refine(spec, best.theta, us, ys, rest)
    final.nfev += screen * len(starts)
    return final


def _best(fits: list[Fit]) -> Fit:
    return min(fits, key=lambda f: f.sse if np.isfinite(f.sse) else np.inf)


# ------------------------------------------------------------------------ process noise

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
    gx = chain.g[0]
    cols, rhs = [], []
    for u, y in zip(us, ys):
        basis = blocks.pwl_expected(gx, np.zeros(len(gx)), chain.linear_sum(u), chain.g_sigma, derivatives=True)[3]
        if chain.h2 is not None:
            b, den, _ = chain.h2
            basis = _filter(b, den, basis)
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
    periods instead (:func:`_noise_from_periods`), and every build in ``alternatives`` (other
    output-error fits of the same orders) is refined too, on the machine's cores
    (:func:`_map_builds`); they are chosen between by the order search's rule
    (the fewest parameters within the noise, :func:`_within_noise`), and the one chosen is kept
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
        refined = _map_builds(partial(_noise_from_periods, us=us, ys=ys, opts=opts, periods=periods), builds)
        parents = {id(f): b for f, b in zip(refined, builds)}
        consistent = [f for f in refined if f.notes["process_noise"]["consistent"]]
        if consistent:
            tied = _within_noise(consistent, n)
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
    spread = float(np.std(np.concatenate([chain.linear_sum(u)[opts.skip :] for u in us]))) or 1.0
    thetas = []
    with np.errstate(all="ignore"):
        for frac in starts:
            theta = np.zeros(spec.n_params)
            cut = old["g.y"].stop
            theta[:cut] = fit.theta[:cut]
            theta[sl["g.s"]] = np.log(frac * spread)
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


def _at_noise_level(fit: Fit, spec: ChainSpec, us, ys, sigma: float, opts: Options, refine_blocks: bool) -> Fit:
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
            basis = _filter(b, den, basis)
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
    sqrt(samples) on its log, so a 1 % change costs as much as the whole simulation error."""

    def __init__(self, spec: ChainSpec, us, skip: int, target: float, n_res: int):
        self.spec, self.us, self.skip = spec, us, skip
        self.log_target = np.log(target)
        self.weight = 100.0 * np.sqrt(n_res)
        self.upstream = np.arange(spec.slices()["g.p"].start)  # the parameters before g

    def _log_spread(self, theta) -> float:
        chain = Chain(self.spec, theta)
        return float(np.log(np.std(np.concatenate([chain.linear_sum(u)[self.skip :] for u in self.us]))))

    def __call__(self, theta):
        base = self._log_spread(theta)
        jac = np.zeros((1, self.spec.n_params))
        for k in self.upstream:  # central differences: only the linear branches move
            h = 1e-6 * max(1.0, abs(theta[k]))
            up, dn = np.array(theta, dtype=float), np.array(theta, dtype=float)
            up[k] += h
            dn[k] -= h
            jac[0, k] = (self._log_spread(up) - self._log_spread(dn)) / (2 * h)
        return np.array([self.weight * (base - self.log_target)]), self.weight * jac


def _noise_from_periods(fit: Fit, us, ys, opts: Options, periods) -> Fit:
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
        trial = _at_noise_level(fit, spec, us, ys, sigma, opts, refine_blocks=False)
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
        out = _at_noise_level(fit, spec, us, ys, sigma, opts, refine_blocks=True)
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


def _map_builds(refine_build, builds: list) -> list:
    """``refine_build`` applied to every build, in order. The builds are independent, so in the
    main process they run on a pool of the machine's cores; inside a worker (the order search
    already spreads its candidates over the cores) they run one after another."""
    workers = min(os.cpu_count() or 1, len(builds))
    if workers < 2 or multiprocessing.parent_process() is not None:
        return [refine_build(f) for f in builds]
    try:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            return list(pool.map(refine_build, builds))
    except (OSError, BrokenProcessPool):  # no processes to be had here: the same work in turn
        return [refine_build(f) for f in builds]


def _within_noise(fits: list[Fit], n: int) -> list[Fit]:
    """The fits whose error is within one standard error of the lowest, the tie of the order
    search's rule (search.SearchResult), with the same standard error
    (metrics.relative_standard_error; twice it for a squared error). Noise-aware builds differ
    in how they split the dynamics between H1 and H2; on the measured benchmark their expected
    outputs agree to 0.2-0.7 % against a standard error of 0.5-0.7 %
    (tools/explore/wh_process_noise_builds.py)."""
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
    Determined when the correction exceeds the spread: the output-error fit then lies farther
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
    return {
        "correction": correction,
        "spread": spread,
        "tied_builds": len(tied),
        "determined": bool(correction > spread),
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
