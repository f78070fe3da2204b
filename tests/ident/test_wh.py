"""The Wiener-Hammerstein model of an order contains the Wiener and Hammerstein models of it.

WH(p, z) is built from the Wiener(p, z) fit (plus a first-order H2 at identity) and from the
Hammerstein(p, z) fit (plus a first-order H1 at identity, or for several inputs an identity g
and H2 after the Hammerstein's branches), each refined jointly; so its simulation error on the
estimation data is never above either model's.
"""

import numpy as np
import pytest

from porosense import ident
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade

# The fits are deterministic; the WH error may only exceed its start by rounding.
REL = 1e-9


@pytest.fixture(scope="module")
def siso():
    """A WH truth (first-order H1, PWL g, second-order H2), random steps, output noise."""
    g = PiecewiseLinear(np.array([-2.0, -0.8, 0.0, 0.7, 2.5]), np.array([-1.2, -0.9, 0.0, 1.4, 1.7]))
    out = OutputChain(
        "y",
        (Branch(0, SOSCascade.from_tf([0.3], [1.0, -0.7])),),
        g=g,
        h2=SOSCascade.from_tf([0.05, 0.04], [1.0, -1.5, 0.62]),
        offset=0.5,
    )
    system = EstimatorStructure(("u",), (out,), ts=0.02)
    rng = np.random.default_rng(41)
    us, ys = [], []
    for _ in range(2):
        u = np.repeat(rng.uniform(-2.4, 2.4, 20), 25)[:, None]
        y = system.simulate(u)[:, 0]
        us.append(u)
        ys.append(y + 0.03 * np.std(y) * rng.standard_normal(len(y)))
    return us, ys


@pytest.fixture(scope="module")
def miso():
    """Two inputs through their own static nonlinearities and dynamics (a Hammerstein-like truth)."""
    rng = np.random.default_rng(5)
    us, ys = [], []
    for _ in range(2):
        u = np.column_stack([np.repeat(rng.uniform(-1, 1, 20), 20), np.repeat(rng.uniform(-1, 1, 20), 20)])
        x = np.tanh(2.0 * u[:, 0]) + 0.5 * u[:, 1] ** 2
        y = np.convolve(x, [0.0, 0.4, 0.3, 0.15])[: len(u)] + 0.02 * rng.standard_normal(len(u))
        us.append(u)
        ys.append(y)
    return us, ys


ORDERS = dict(n_poles=2, n_zeros=1, n_breakpoints=5, max_nfev=60)


@pytest.mark.parametrize("data", ["siso", "miso"])
def test_wh_error_is_at_most_the_wiener_and_hammerstein_errors_of_its_order(request, data):
    us, ys = request.getfixturevalue(data)
    w = ident.Wiener(**ORDERS).fit(u=us, y=ys, ts=0.02)
    h = ident.Hammerstein(**ORDERS).fit(u=us, y=ys, ts=0.02)
    # From their solutions (as the order search does) and on its own (it fits them itself).
    reused = ident.WienerHammerstein(**ORDERS).fit(u=us, y=ys, ts=0.02, wiener=w, hammerstein=h)
    alone = ident.WienerHammerstein(**ORDERS).fit(u=us, y=ys, ts=0.02)
    bound = min(w.info["sse"], h.info["sse"]) * (1 + REL)
    print(
        data,
        {
            "wiener": w.info["sse"],
            "hammerstein": h.info["sse"],
            "wh": reused.info["sse"],
            "wh alone": alone.info["sse"],
            "build": reused.info["build"],
        },
    )
    assert reused.info["sse"] <= bound
    assert alone.info["sse"] <= bound
    # The same comparison as fit % on the estimation recordings.
    fit = {k: np.mean(m.score(u=us, y=ys)["fit"]) for k, m in (("w", w), ("h", h), ("wh", reused))}
    assert fit["wh"] >= max(fit["w"], fit["h"]) - 1e-6


@pytest.mark.parametrize("data", ["siso", "miso"])
def test_both_wh_builds_start_at_their_models_and_convert_to_the_estimator(request, data):
    us, ys = request.getfixturevalue(data)
    w = ident.Wiener(**ORDERS).fit(u=us, y=ys, ts=0.02)
    h = ident.Hammerstein(**ORDERS).fit(u=us, y=ys, ts=0.02)
    wh = ident.WienerHammerstein(**ORDERS).fit(u=us, y=ys, ts=0.02, wiener=w, hammerstein=h)
    members = {m.info["build"]: m for m in [wh] + wh.alternative_models()}
    routes = {"wiener+linear", "linear+hammerstein", "wiener+linear start", "linear+hammerstein start"}
    assert routes <= set(members)
    if data == "miso":  # no BLA split with several inputs
        assert set(members) == routes
    members = {b: m for b, m in members.items() if b in routes}
    u = us[0]
    # The starts simulate exactly like the Wiener and Hammerstein models they came from.
    for build, parent in (("wiener+linear start", w), ("linear+hammerstein start", h)):
        err = np.max(np.abs(members[build].predict(u=u) - parent.predict(u=u)))
        assert err < 1e-9 * (1 + np.max(np.abs(u)))
    for build, m in members.items():
        s = m.to_structure()
        s.check_limits()
        out = s.outputs[0]
        assert out.kind == "wh" and out.g is not None and out.h2 is not None
        # One linear block carries the order (2 poles), the other is one first-order section
        # (1 pole, 1 zero: a2 = b2 = 0).
        h2_first = build.startswith("wiener") or data == "miso"
        first_order, order = (out.h2, out.branches[0].h1) if h2_first else (out.branches[0].h1, out.h2)
        assert first_order.n_sections == 1 and first_order.sos[0, 5] == 0.0 and first_order.sos[0, 2] == 0.0
        assert order.n_sections == 1 and order.sos[0, 5] != 0.0
        assert np.max(np.abs(s.simulate(u)[:, 0] - m.predict(u=u))) < 1e-9 * (1 + np.max(np.abs(m.predict(u=u))))
    if data == "miso":
        # The Hammerstein build keeps one nonlinearity per input before the branches.
        assert all(br.f is not None for br in members["linear+hammerstein"].to_structure().outputs[0].branches)


def test_bla_split_build_starts_at_the_linear_model_and_only_improves(siso):
    us, ys = siso
    orders = dict(n_poles=3, n_zeros=1, max_nfev=60)
    lin = ident.Linear(**orders).fit(u=us, y=ys, ts=0.02)
    wh = ident.WienerHammerstein(n_breakpoints=5, **orders).fit(u=us, y=ys, ts=0.02, linear=lin)
    members = {m.info["build"]: m for m in [wh] + wh.alternative_models()}
    start = members["bla split start"]
    u = us[0]
    # Identity g and H1 H2 equal to the linear model: the same simulation to rounding.
    assert np.max(np.abs(start.predict(u=u) - lin.predict(u=u))) < 1e-8 * (1 + np.max(np.abs(lin.predict(u=u))))
    split_fits = [m for b, m in members.items() if b.startswith("bla split (")]
    assert split_fits
    print({b: m.info["sse"] for b, m in members.items()}, "linear", lin.info["sse"])
    assert all(m.info["sse"] <= lin.info["sse"] * (1 + REL) for m in split_fits)
    # The truth is WH (1 + 2 poles): the split build must clearly beat the linear model (<= 1/2 its SSE).
    assert min(m.info["sse"] for m in split_fits) <= 0.5 * lin.info["sse"]
    for m in split_fits:
        m.to_structure().check_limits()


def test_ten_pole_wh_fits_the_firmware_limits(siso):
    us, ys = siso
    wh = ident.WienerHammerstein(n_poles=10, n_zeros=9, n_breakpoints=16, max_nfev=4, starts=1)
    wh.fit(u=[u[:300] for u in us], y=[y[:300] for y in ys], ts=0.02)
    for m in [wh] + wh.alternative_models():
        s = m.to_structure()
        s.check_limits()
        out = s.outputs[0]
        sections = sorted([out.h2.n_sections, out.branches[0].h1.n_sections])
        # The BLA split builds share the 10 poles between the blocks; the routes add one section.
        assert sections[1] <= 5
        if not m.info["build"].startswith("bla split"):
            assert sections[0] == 1
