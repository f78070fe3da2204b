"""Circle fit: curvature and its stated uncertainty on random noisy arcs (no video)."""

from __future__ import annotations

import numpy as np
import pytest

from porosense.record.circle import fit_circle


def _arc(rng, kappa, n, length, noise):
    s = np.linspace(-length / 2, length / 2, n)
    th = s * kappa
    if abs(kappa) < 1e-12:
        pts = np.c_[s, np.zeros(n)]
    else:
        pts = np.c_[np.sin(th) / kappa, (1 - np.cos(th)) / kappa]
    rot = np.array([[0.6, -0.8], [0.8, 0.6]])  # an arbitrary rotation and shift
    return pts @ rot.T + [120.0, -40.0] + rng.normal(0, noise, (n, 2))


def test_curvature_errors_match_stated_uncertainty():
    """Six random arc set-ups (bent up to 2.5 rad, either sign, 5-15 points, noise 0.01-0.3),
    300 noise draws each: the fits are unbiased (mean error within 4 standard errors) and the
    spread of the curvature agrees with the stated std (rms over the draws) within 15 %:
    with 300 draws both estimates carry ~4-6 % sampling error, so 15 % is about 3 sigma."""
    rng = np.random.default_rng(42)
    for _ in range(6):
        length = rng.uniform(60, 150)
        kappa = rng.uniform(0, 2.5 / length) * rng.choice([-1, 1])
        n = int(rng.integers(5, 16))
        noise = rng.uniform(0.01, 0.3)
        seed = int(rng.integers(1 << 30))
        fits = [fit_circle(_arc(np.random.default_rng([seed, k]), kappa, n, length, noise)) for k in range(300)]
        est = np.array([f.curvature for f in fits])
        stated = float(np.sqrt(np.mean([f.curvature_std**2 for f in fits])))
        spread = float(est.std(ddof=1))
        print(
            f"kappa {kappa:+.4f}, {n} points, noise {noise:.2f}: bias {est.mean() - kappa:+.2e}, "
            f"spread {spread:.2e}, stated {stated:.2e}"
        )
        assert abs(est.mean() - kappa) < 4 * spread / np.sqrt(len(est))
        assert 0.85 < spread / stated < 1.15


def test_straight_line_gives_zero_curvature():
    rng = np.random.default_rng(3)
    pts = _arc(rng, 0.0, 9, 100.0, 0.05)
    fit = fit_circle(pts)
    assert abs(fit.curvature) < 4 * fit.curvature_std


def test_needs_three_points():
    with pytest.raises(ValueError):
        fit_circle([[0, 0], [1, 1]])
