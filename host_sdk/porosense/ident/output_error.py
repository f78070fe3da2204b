"""Output-error estimation of every structure, with the starting points of the paper.

Linear models start from ARX / instrumental variables; Hammerstein and Wiener models from the
best linear model of their order; Wiener-Hammerstein models are built both of the paper's ways
and from the best split of the linear model's poles and zeros (:mod:`bla_split`), each refined
jointly (:func:`porosense.ident.refine.refine`). Normalised data as in :mod:`refine`.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from porosense.ident import bla_split, blocks
from porosense.ident.chain import Chain, ChainSpec, block_filter
from porosense.ident.linear_init import arx, iv
from porosense.ident.refine import Fit, Options, lstsq, multistart, refine, sse

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
    assert best is not None  # the loop ran twice
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
            blocks_i.append(block_filter(b, den, _hat_basis(xs[i], xin[i])))
        cols.append(np.hstack(blocks_i + [np.ones((len(u), 1))]))
    phi = np.vstack(cols)
    sol = lstsq(phi, np.concatenate(ys))
    if np.all(np.isfinite(sol)):
        fys = [sol[i * n_bp : (i + 1) * n_bp] for i in range(n_in)]
        starts.append(theta_with(fys, sol[-1]))
    return spec, starts[: max(opts.starts, 1)]


def bla_options(opts: Options) -> Options:
    """The linear model a nonlinear one starts from: the best linear model of its order (fully
    refined), so that the nonlinear model's first iterate already equals the linear fit."""
    return Options(max_nfev=opts.max_nfev, tol=opts.tol, skip=opts.skip, starts=1)


def fit_hammerstein(us, ys, n_poles, n_zeros, n_bp, delay, opts: Options, lin: Fit | None = None) -> Fit:
    """f_i then B_i/F_i; best of the multi-start refinements from the best linear approximation."""
    lin = lin or fit_linear(us, ys, n_poles, n_zeros, delay, bla_options(opts))
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
    lin = lin or fit_linear(us, ys, n_poles, n_zeros, delay, bla_options(opts))
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
        lin = fit_linear(us, ys, n_poles, n_zeros, delay, bla_options(opts))
    if wiener is None or hammerstein is None:
        wiener = wiener or fit_wiener(us, ys, n_poles, n_zeros, n_bp, delay, opts, lin=lin)
        hammerstein = hammerstein or fit_hammerstein(us, ys, n_poles, n_zeros, n_bp, delay, opts, lin=lin)
    builds, starts = [], []
    for build, (spec, theta0), parent in (
        ("wiener+linear", wiener_plus_linear(wiener), wiener),
        ("linear+hammerstein", linear_plus_hammerstein(hammerstein, us, n_bp), hammerstein),
    ):
        start = sse(spec, theta0, us, ys, opts.skip)
        # The start is the parent model itself; only rounding may separate the two errors.
        if not start <= parent.sse * (1 + 1e-9) + 1e-12:
            raise ArithmeticError(f"WH start {build}: error {start} above its model's {parent.sse}")
        builds.append(Fit(spec, theta0, start, 0, build))
        starts.append(Fit(spec, theta0, start, 0, build + " start"))
    if lin is not None:
        # The best-scored split only: the two routes are the other starts (cost of the paper's grid).
        for _, spec, theta_ls, theta_identity, split in bla_split.ranked_split_starts(
            lin.spec, lin.theta, us, ys, n_bp, opts.skip, keep=1
        ):
            builds.append(
                Fit(spec, theta_ls, sse(spec, theta_ls, us, ys, opts.skip), 0, f"bla split ({split.describe()})")
            )
            starts.append(Fit(spec, theta_identity, sse(spec, theta_identity, us, ys, opts.skip), 0, "bla split start"))
    fits = race(builds, us, ys, opts)
    return fits + starts


def race(builds: list[Fit], us, ys, opts: Options) -> list[Fit]:
    """Every build (its start in ``theta``) refined for a fifth of the budget, then the best one
    continued with the rest; best first. A refinement never returns a higher error than its
    start, so the best is at most the lowest start's error (each WH build starts exactly at the
    Wiener, Hammerstein or linear model it is built from)."""
    if len(builds) == 1:
        short = opts
    else:
        short = replace(opts, max_nfev=max(opts.max_nfev // 5, 8))
    fits = []
    for b in builds:
        fit = refine(b.spec, b.theta, us, ys, short)
        if not fit.sse <= b.sse:  # a failed (or rounding-only) refinement: keep the start
            fit = Fit(b.spec, b.theta, b.sse, fit.nfev, converged=True)
        fit.build = b.build
        fits.append(fit)
    fits.sort(key=lambda f: f.sse if np.isfinite(f.sse) else np.inf)
    if short is not opts and not fits[0].converged:
        best = fits[0]
        rest = refine(best.spec, best.theta, us, ys, replace(opts, max_nfev=max(opts.max_nfev - short.max_nfev, 1)))
        if rest.sse <= best.sse:
            rest.nfev += best.nfev
            rest.build = best.build
            fits[0] = rest
    return fits
