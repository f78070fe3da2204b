"""Wiener-Hammerstein starts from the best linear approximation (BLA), its poles and zeros split.

A WH system H2(g(H1 u)) has a BLA proportional to H1 H2. Every way of giving each pole (a
conjugate pair moves as one) and each zero of the BLA to H1 or to H2 is a candidate WH model
that, with g the identity, simulates exactly as the BLA. For each split the values of g (a
piecewise-linear map on the quantiles of H1's output) enter the output linearly,

    y - c = sum_k gy_k H2(hat_k(H1 u)),

so one least-squares solve scores the split. The best-scoring splits are the starts of the
joint refinement; the identity-g start (equal to the linear model) is always kept as well.
SISO only (several inputs have a denominator per branch, which no single split covers).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from porosense.ident import blocks
from porosense.ident.chain import Chain, ChainSpec, block_filter

# The number of splits grows as 2^(pole groups + zero groups): at most MAX_SPLITS are scored
# (pole allocations in the outer loop, so every pole split is reached before zero variants are
# cut), each on at most SCORE_SAMPLES samples.
MAX_SPLITS = 512
SCORE_SAMPLES = 4000


@dataclass
class Split:
    """One allocation of the BLA's roots: H1 = k1 B1/A1, H2 = B2/A2 (unit DC gain)."""

    poles1: np.ndarray
    zeros1: np.ndarray
    poles2: np.ndarray
    zeros2: np.ndarray
    score: float = float("inf")

    def describe(self) -> str:
        return (
            f"H1 {len(self.poles1)} poles {len(self.zeros1)} zeros | "
            f"H2 {len(self.poles2)} poles {len(self.zeros2)} zeros"
        )


def _groups(roots) -> list[np.ndarray]:
    """Roots grouped so that complex conjugates stay together."""
    roots = np.asarray(roots, dtype=complex)
    out = [np.array([r, np.conj(r)]) for r in roots if r.imag > 1e-9]
    out += [np.array([r.real + 0j]) for r in roots if abs(r.imag) <= 1e-9]
    return out


def _poly(roots) -> np.ndarray:
    return np.real(np.poly(roots)) if len(roots) else np.ones(1)


def enumerate_splits(poles, zeros) -> list[Split]:
    """Splits with at least one pole in each block and zeros <= poles in each block.

    Every pole allocation is kept; when pole x zero allocations exceed MAX_SPLITS, each pole
    allocation gets only its first MAX_SPLITS // (pole allocations) zero allocations.
    """
    pg, zg = _groups(poles), _groups(zeros)
    cat = lambda gs: np.concatenate(gs) if gs else np.zeros(0, complex)
    pole_splits = []
    for pm in itertools.product((0, 1), repeat=len(pg)):
        p1 = cat([g for g, m in zip(pg, pm) if m == 0])
        p2 = cat([g for g, m in zip(pg, pm) if m == 1])
        if len(p1) and len(p2):
            pole_splits.append((p1, p2))
    per_pole = max(1, MAX_SPLITS // max(len(pole_splits), 1))
    out = []
    for p1, p2 in pole_splits:
        kept = 0
        for zm in itertools.product((0, 1), repeat=len(zg)):
            z1 = cat([g for g, m in zip(zg, zm) if m == 0])
            z2 = cat([g for g, m in zip(zg, zm) if m == 1])
            if len(z1) > len(p1) or len(z2) > len(p2):
                continue
            out.append(Split(p1, z1, p2, z2))
            kept += 1
            if kept >= per_pole:
                break
    return out


def _unit_dc(b, a):
    """Scale b so that b/a has unit gain at DC (or at its largest response if DC is ~0)."""
    dc = np.sum(b) / np.sum(a)
    if abs(dc) < 1e-6:
        w = np.linspace(0, np.pi, 256)
        zi = np.exp(-1j * w)
        h = np.polyval(b[::-1], zi) / np.polyval(a[::-1], zi)
        dc = np.max(np.abs(h))
    return b / dc


def split_start(lin_spec: ChainSpec, lin_theta, split: Split, n_bp: int, us):
    """(spec, theta, s-signals) of the WH model equal to the linear model with ``split``; g identity."""
    chain = Chain(lin_spec, lin_theta)
    b, den, _ = chain.h1[0]
    lead = np.flatnonzero(np.abs(b) > 0)
    b0 = b[lead[0]] if len(lead) else 1.0
    delay_b = int(lead[0]) if len(lead) else 0
    a1, a2 = _poly(split.poles1), _poly(split.poles2)
    bz1, bz2 = _poly(split.zeros1), _poly(split.zeros2)
    b2 = _unit_dc(bz2, a2)
    # H1 carries the remaining gain and the numerator's leading delay.
    b1 = np.concatenate([np.zeros(delay_b), bz1 * b0 / b2[0]])
    np1, np2 = len(split.poles1), len(split.poles2)
    nz1, nz2 = len(b1) - 1, len(b2) - 1
    spec = ChainSpec(1, np1, nz1, g_bp=n_bp, h2=True, np2=np2, nz2=nz2, delay=lin_spec.delay)
    sl = spec.slices()
    theta = np.zeros(spec.n_params)
    theta[sl["h10.a"]] = blocks.theta_from_poly(a1, np1)
    theta[sl["h10.b"]] = b1
    theta[sl["h2.a"]] = blocks.theta_from_poly(a2, np2)
    theta[sl["h2.b"]] = b2
    theta[sl["offset"]] = chain.offset
    c = Chain(ChainSpec(1, np1, nz1, delay=lin_spec.delay), np.concatenate([theta[sl["h10.a"]], b1, [0.0]]))
    ss = [c.linear_sum(u) for u in us]
    x = blocks.initial_breakpoints(np.concatenate(ss), n_bp)
    theta[sl["g.p"]] = blocks.positions_to_p(x)
    theta[sl["g.y"]] = x
    return spec, theta, ss


def score_split(spec: ChainSpec, theta, ss, ys, skip: int):
    """(sse, theta with least-squares g values and offset) for one split start."""
    sl = spec.slices()
    x, _ = blocks.pwl_positions(theta[sl["g.p"]])
    den2, _ = blocks.sections(theta[sl["h2.a"]])
    b2 = theta[sl["h2.b"]]
    cols = []
    for s in ss:
        hat = blocks.pwl_eval(x, np.zeros(len(x)), s, derivatives=True)[3]
        cols.append(np.hstack([block_filter(b2, den2, hat), np.ones((len(s), 1))])[skip:])
    phi = np.vstack(cols)
    rhs = np.concatenate([y[skip:] for y in ys])
    # Normal equations (small, ridge-guarded): far cheaper than an SVD-based solve per split.
    gram = phi.T @ phi
    ridge = 1e-10 * np.trace(gram) / len(gram)
    try:
        sol = np.linalg.solve(gram + ridge * np.eye(len(gram)), phi.T @ rhs)
    except np.linalg.LinAlgError:
        return np.inf, theta
    if not np.all(np.isfinite(sol)):
        return np.inf, theta
    out = theta.copy()
    out[sl["g.y"]] = sol[:-1]
    out[sl["offset"]] = sol[-1]
    return float(np.sum((phi @ sol - rhs) ** 2)), out


def ranked_split_starts(lin_spec: ChainSpec, lin_theta, us, ys, n_bp: int, skip: int, keep: int = 3):
    """The ``keep`` best splits of the linear model's roots as (spec, theta, Split), best first,
    each with least-squares g values. Empty for several inputs or fewer than 2 poles."""
    if lin_spec.n_inputs != 1 or lin_spec.np1 < 2:
        return []
    chain = Chain(lin_spec, lin_theta)
    b, den, _ = chain.h1[0]
    a = blocks.den_poly(den)
    poles = np.roots(a)
    bt = np.trim_zeros(np.trim_zeros(np.asarray(b, float), "f"), "b")
    zeros = np.roots(bt) if len(bt) > 1 else np.zeros(0)
    # Rank on at most SCORE_SAMPLES samples (the ranking, not the value, matters), then solve
    # for g on all the data for the splits kept.
    short_u, short_y = _head(us, ys, SCORE_SAMPLES + skip * len(us))
    ranked = []
    for split in enumerate_splits(poles, zeros):
        spec, theta, ss = split_start(lin_spec, lin_theta, split, n_bp, short_u)
        split.score, _ = score_split(spec, theta, ss, short_y, skip)
        ranked.append(split)
    ranked.sort(key=lambda sp: sp.score)
    out = []
    for split in ranked[:keep]:
        spec, theta, ss = split_start(lin_spec, lin_theta, split, n_bp, us)
        sse, theta_ls = score_split(spec, theta, ss, ys, skip)
        out.append((sse, spec, theta_ls, theta, split))
    return out


def _head(us, ys, n_max: int):
    """The first records (the last one cut) holding at most ``n_max`` samples in all."""
    out_u, out_y, left = [], [], n_max
    for u, y in zip(us, ys):
        if left <= 0:
            break
        out_u.append(u[:left])
        out_y.append(y[:left])
        left -= len(y)
    return out_u, out_y
