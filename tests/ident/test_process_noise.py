"""Process noise at the static map's input (``process_noise=True``, ``identify --process-noise``).

The data come from an independent generator written here: a WH system with random stable
H1 and H2 (1-2 poles each, unit DC gain), a random piecewise-linear g with 2-3 kinks at
random places and slopes over a decade, and a coloured Gaussian noise added at g's input with
a standard deviation of 0.3-0.7 of g's input (fixed seeds). The identification code never
generated these records.
"""

import copy
import importlib
import json
import os

import numpy as np
import pytest
from scipy.signal import lfilter

from porosense import ident
from porosense.errors import InputError
from porosense.ident import blocks, noise_level
from porosense.ident.chain import Chain

SKIP = 50
N = 4000


def _stable(rng, n_poles):
    poles = []
    while len(poles) < n_poles:
        if n_poles - len(poles) >= 2 and rng.random() < 0.5:
            r, a = rng.uniform(0.5, 0.95), rng.uniform(0.05, 1.2)
            poles += [r * np.exp(1j * a), r * np.exp(-1j * a)]
        else:
            poles.append(rng.uniform(0.3, 0.95))
    den = np.real(np.poly(poles))
    num = np.array([1.0, rng.uniform(-0.5, 0.5)])
    return num * np.sum(den) / np.sum(num), den


def _system(seed):
    """(simulate(u, noise_std, out_noise), noise_std) of one random WH system."""
    rng = np.random.default_rng(seed)
    h1, h2 = _stable(rng, int(rng.integers(1, 3))), _stable(rng, int(rng.integers(1, 3)))
    nk = int(rng.integers(2, 4))
    kx = np.sort(rng.uniform(-1.2, 1.2, nk))
    ks = rng.uniform(-1, 1, nk + 1) * rng.choice([0.1, 1.0, 3.0], nk + 1)

    def g(x):
        return ks[0] * x + sum((ks[i + 1] - ks[i]) * np.maximum(x - kx[i], 0.0) for i in range(nk))

    def simulate(u, noise_std, out_noise=0.0):
        x = lfilter(*h1, u)
        v = lfilter([1.0], [1.0, -0.5], rng.standard_normal(len(u)))
        y = lfilter(*h2, g(x + noise_std * v / np.std(v)))
        return y + out_noise * rng.standard_normal(len(u))

    gain = 1.0 / np.std(lfilter(*h1, rng.standard_normal(20000)))  # g's input at unit spread
    return simulate, rng.uniform(0.3, 0.7), gain, rng


def test_expected_map_matches_monte_carlo_and_its_derivatives():
    rng = np.random.default_rng(7)
    x = np.sort(rng.uniform(-2, 2, 7))
    y = rng.normal(size=7)
    u = rng.uniform(-3, 3, 40)
    sigma = 0.4
    v = sigma * rng.standard_normal(100_000)
    mc = np.array([blocks.pwl_eval(x, y, ui + v) for ui in u])
    z, slope, dz_dx, dz_dy, dz_ds = blocks.pwl_expected(x, y, u, sigma, derivatives=True)
    # Monte Carlo: within 5 standard errors of the sample mean.
    assert np.all(np.abs(mc.mean(axis=1) - z) <= 5 * mc.std(axis=1) / np.sqrt(len(v)) + 1e-12)
    e = 1e-6
    num = lambda f: (f(e) - f(-e)) / (2 * e)  # noqa: E731
    assert np.max(np.abs(num(lambda h: blocks.pwl_expected(x, y, u + h, sigma)) - slope)) < 1e-6
    assert np.max(np.abs(num(lambda h: blocks.pwl_expected(x, y, u, sigma + h)) - dz_ds)) < 1e-6
    for k in range(len(x)):
        ek = np.eye(len(x))[k]
        assert np.max(np.abs(num(lambda h: blocks.pwl_expected(x + h * ek, y, u, sigma)) - dz_dx[:, k])) < 1e-6
        assert np.max(np.abs(num(lambda h: blocks.pwl_expected(x, y + h * ek, u, sigma)) - dz_dy[:, k])) < 1e-6
    # sigma -> 0 is the map itself.
    assert np.max(np.abs(blocks.pwl_expected(x, y, u, 1e-9) - blocks.pwl_eval(x, y, u))) < 1e-9


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noise_aware_fit_against_output_error_fit(seed):
    """What holds, asserted: the noise-aware model's expected output fits the estimation data
    at least as well as the output-error (OE) fit it was refined from (a member of the model).

    What does NOT hold (printed, not asserted): the goal that it recovers the noise-free output
    clearly better than the OE fit. Measured over seeds 0-5 (N = 2 x 4000, 2 poles, 10
    breakpoints): the noise-free test RMSE ratio (noise-aware / OE) is 0.99-1.08 in most runs,
    and on seed 0 it has reached 1100 (a deconvolved g that explodes outside the data); the
    estimated sigma is 0.5-5 % of the spread of g's input against a true 30-70 %. From the
    mean output alone the noise is not identifiable: g' = g * N(0, s^2 - s'^2) with noise s'
    gives the same expected output as g with noise s, and the cost is flat in sigma to 0.5 %
    (seed 0, sigma from 1 % to 50 % of the spread).
    """
    simulate, noise, gain, rng = _system(seed)
    us = [gain * rng.standard_normal(N) for _ in range(2)]
    ys = [simulate(u, noise, 0.01) for u in us]
    ut = gain * rng.standard_normal(N)
    yt = simulate(ut, 0.0)
    kw = dict(n_poles=2, n_zeros=1, n_breakpoints=10, skip=SKIP, starts=1, max_nfev=100)
    pn = ident.WienerHammerstein(**kw, process_noise=True).fit(u=[u[:, None] for u in us], y=ys, ts=1.0)
    oe = pn.alternative_models()[0]  # the OE fit the noise model was refined from
    assert pn.spec.g_noise and not oe.spec.g_noise and pn.process_noise_std > 0
    sse = lambda m: sum(
        np.sum((m.predict(u=u[:, None], expected=True) - y)[SKIP:] ** 2)  # noqa: E731
        for u, y in zip(us, ys)
    )
    assert sse(pn) <= sse(oe) * (1 + 1e-9)
    e_oe = ident.rmse(yt[SKIP:], oe.predict(u=ut[:, None])[SKIP:])
    e_pn = ident.rmse(yt[SKIP:], pn.predict(u=ut[:, None])[SKIP:])
    print(
        f"seed {seed}: expected-output SSE {sse(pn):.4g} vs OE {sse(oe):.4g}; noise-free test RMSE "
        f"noise-aware {e_pn:.4g}, OE {e_oe:.4g} (ratio {e_pn / e_oe:.3g}), sigma {pn.process_noise_std:.3g}"
    )


def test_process_noise_model_saves_loads_and_quantizes_as_the_noise_free_map(tmp_path):
    simulate, noise, gain, rng = _system(3)
    u = gain * rng.standard_normal(1500)
    y = simulate(u, noise)
    m = ident.Wiener(n_poles=2, n_zeros=1, n_breakpoints=6, max_nfev=30, starts=1, process_noise=True)
    m.fit(u=u[:, None], y=y, ts=0.02, input_unit="dR/100", output_unit="%")
    back = ident.load_model(m.save(tmp_path / "m.json"))
    assert back.process_noise and back.process_noise_std == m.process_noise_std > 0
    for expected in (False, True):
        assert np.array_equal(back.predict(u=u[:, None], expected=expected), m.predict(u=u[:, None], expected=expected))
    # The structure the board runs is the noise-free model: equal to predict() to rounding.
    s = m.to_structure()
    assert s.meta["process_noise_std"] == m.process_noise_std
    free = m.predict(u=u[:, None])
    assert np.max(np.abs(s.simulate(u[:, None])[:, 0] - free)) <= 1e-9 * np.max(np.abs(free))
    assert np.max(np.abs(m.predict(u=u[:, None], expected=True) - free)) > 0
    assert json.loads((tmp_path / "m.json").read_text())["models"][0]["options"]["process_noise"] is True


def test_process_noise_needs_a_map_g():
    for kind in ("linear", "hammerstein"):
        with pytest.raises(InputError, match="process noise"):
            ident.make_model(kind, process_noise=True)


def test_search_passes_units_and_process_noise_to_its_models(tmp_path):
    simulate, noise, gain, rng = _system(4)
    us = [gain * rng.standard_normal(800)[:, None] for _ in range(2)]
    ys = [simulate(u[:, 0], noise) for u in us]
    res = ident.search(
        u=us[:1],
        y=ys[:1],
        ts=0.02,
        validation=(us[1:], ys[1:]),
        grid=[("linear", 1, 0), ("wh", 1, 0)],
        n_breakpoints=4,
        max_nfev=15,
        starts=1,
        progress=False,
        criterion="fit",
        process_noise=True,
        input_unit="dR/100",
        output_unit="%",
    )
    assert {c.structure for c in res.candidates} == {"linear", "wh"}
    for c in res.candidates:
        assert c.model.input_units == ("dR/100",) and c.model.output_unit == "%"
        doc = json.loads(c.model.save(tmp_path / f"{c.structure}.json").read_text())["models"][0]
        assert doc["signals"]["inputs"][0]["unit"] == "dR/100" and doc["signals"]["output"]["unit"] == "%"


def test_search_refits_only_the_best_wiener_and_wh_with_process_noise():
    """With process_noise the search runs as without it, then refits the best Wiener and the
    best WH candidate with the noise (a process-noise fit costs many output-error fits); every
    other candidate stays the output-error fit, and the rule names the refitted ones. Measured
    (seed 2, 2 + 1 records of 2 x 800 samples): Wiener 2p1z 55.73 % validation fit before the refit,
    55.90 % after it with the noise; WH 2p1z 58.38 % and 58.61 %."""
    us, ys, _ = _periodic_records(2, n_records=3, period=800)
    us = [u[:, None] for u in us]
    grid = [("linear", 1, 0), ("linear", 2, 1), ("wiener", 1, 0), ("wiener", 2, 1), ("wh", 1, 0), ("wh", 2, 1)]
    kw = dict(
        u=us[:2],
        y=ys[:2],
        ts=0.02,
        validation=(us[2:], ys[2:]),
        validation_skip=SKIP,
        skip=SKIP,
        grid=grid,
        n_breakpoints=6,
        max_nfev=20,
        starts=1,
        progress=False,
        criterion="fit",
    )
    oe = ident.search(**kw)
    pn = ident.search(**kw, process_noise=True)
    tie_tolerance = ident.tie_tolerance
    assert "process noise fitted for wiener" in pn.rule and ", wh " in pn.rule, pn.rule
    for structure in ("wiener", "wh"):
        top = max((c for c in oe.candidates if c.structure == structure), key=lambda c: c.score("fit"))
        after = {(c.n_poles, c.n_zeros): c for c in pn.candidates if c.structure == structure}
        refit = after.pop((top.n_poles, top.n_zeros))
        # The finalist is the noise fit or an output-error fit; its score is never more than one
        # standard error below the output-error candidate it replaced.
        assert refit.score("fit") >= top.score("fit") - tie_tolerance(top, "fit") - 1e-9
        print(
            f"{structure} {top.n_poles}p{top.n_zeros}z: OE {top.score('fit'):.3f} %, "
            f"after the refit {refit.score('fit'):.3f} % (process noise: {refit.model.spec.g_noise})"
        )
        # The other orders are the output-error fits, parameter for parameter.
        for (p, z), c in after.items():
            same = next(o for o in oe.candidates if (o.structure, o.n_poles, o.n_zeros) == (structure, p, z))
            assert not c.model.spec.g_noise and np.allclose(c.model.theta, same.model.theta)


def _search_data(us, ys, val):
    """The records of a search as the order search scores its candidates on them."""
    tasks = importlib.import_module("porosense.ident.tasks")
    scaling = ident.models.Scaling.of(us, ys)
    return tasks.SearchData(us, ys, 1.0, SKIP, val, scaling, us, ys, SKIP)


def _periodic_records(seed, n_records=2, period=2000):
    """Records of the independent generator whose input repeats once (two periods each)."""
    simulate, noise, gain, rng = _system(seed)
    us = [np.tile(gain * rng.standard_normal(period), 2) for _ in range(n_records)]
    ys = [simulate(u, noise, 0.01) for u in us]
    return us, ys, noise


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noise_level_from_repeated_periods(seed):
    """With a repeated input the noise level is identified (the mean alone cannot fix it).

    The generator's true level is 0.3-0.7 of the spread of g's input (its noise is AR(1); the
    estimator assumes only a spectrum piecewise constant over bands). Measured over seeds 0-7
    (2 records x 2 periods x 2000 samples, 10 breakpoints, 40 evaluations): estimate / truth
    0.64-1.63 (0.5-5 % against 30-70 % without periods). Bound: within a factor 2. The
    noise-free test RMSE against the OE fit is printed, not asserted: noise-aware / OE 0.48,
    0.50, 0.74, 1.39, 0.90, 1.49, 0.64, 2.37 over seeds 0-7, better in 5 of 8 (the deconvolved
    g is only as good as the blocks it sits between, and these maps have sharp kinks).
    """
    us, ys, noise = _periodic_records(seed)
    m = ident.WienerHammerstein(
        n_poles=2, n_zeros=1, n_breakpoints=10, skip=SKIP, starts=1, max_nfev=40, process_noise=True
    ).fit(u=[u[:, None] for u in us], y=ys, ts=1.0)
    info = m.info["process_noise"]
    assert info["method"] == "repeated periods" and "2 recording(s) repeat" in info["periods"]
    est = info["sigma_per_spread"]
    simulate, _, gain, rng = _system(seed)
    ut = gain * rng.standard_normal(N)
    yt = simulate(ut, 0.0)
    oe = m.alternative_models()[0]
    e_oe = ident.rmse(yt[SKIP:], oe.predict(u=ut[:, None])[SKIP:])
    e_pn = ident.rmse(yt[SKIP:], m.predict(u=ut[:, None])[SKIP:])
    print(
        f"seed {seed}: noise level estimate {est:.3f} of g's input spread, truth {noise:.3f} "
        f"(ratio {est / noise:.2f}); period power ratio {info['power_ratio']:.3f}; noise-free test "
        f"RMSE noise-aware / OE {e_pn / e_oe:.2f}"
    )
    assert abs(np.log(est / noise)) < np.log(2.0)
    assert abs(np.log(info["power_ratio"])) < 0.25
    colour = info["colour"]  # the period-difference colour diagnostic (tests/ident/test_noise_colour.py)
    assert colour["dof"] >= 1 and 0.0 <= colour["p_value"] <= 1.0 and colour["refuted"] == (colour["p_value"] < 0.01)
    line = importlib.import_module("porosense.cli.identify")._process_noise_line(m)
    assert f"p = {colour['p_value']:.2g}" in line and ("does not explain" in line) == colour["refuted"]


def test_builds_refined_on_a_pool_equal_the_ones_refined_in_turn(monkeypatch):
    """The process-noise builds are independent: refined on the machine's cores they give the
    same model, parameter for parameter, as refined one after another (one core)."""
    us, ys, _ = _periodic_records(3)
    kw = dict(n_poles=2, n_zeros=1, n_breakpoints=6, skip=SKIP, starts=1, max_nfev=15, process_noise=True)
    monkeypatch.setattr("os.cpu_count", lambda: 2)
    pooled = ident.WienerHammerstein(**kw).fit(u=[u[:, None] for u in us], y=ys, ts=1.0)
    monkeypatch.setattr("os.cpu_count", lambda: 1)
    in_turn = ident.WienerHammerstein(**kw).fit(u=[u[:, None] for u in us], y=ys, ts=1.0)
    assert pooled.info["build"] == in_turn.info["build"]
    assert np.max(np.abs(pooled.theta - in_turn.theta)) <= 1e-12 * max(1.0, np.max(np.abs(in_turn.theta)))


def test_builds_are_refined_in_turn_when_no_process_can_be_started(monkeypatch):
    """A machine that refuses new processes still gets its model, the same one."""
    from porosense.ident import process_noise

    def refuse(*args, **kwargs):
        raise OSError("no processes")

    monkeypatch.setattr("os.cpu_count", lambda: 2)
    monkeypatch.setattr(process_noise, "local_pool", refuse)
    assert process_noise.map_builds(abs, [-3, 2, -1]) == [3, 2, 1]


def test_repeated_period_detection():
    rng = np.random.default_rng(11)
    base = rng.standard_normal(700)
    assert noise_level.repeated_period(np.tile(base, 2)) == 700
    assert (
        noise_level.repeated_period(np.tile(base, 3)[:, None]) == 1050
        or noise_level.repeated_period(np.tile(base, 3)[:, None]) == 700
    )
    assert noise_level.repeated_period(rng.standard_normal(2100)) == 0
    # A repeat that differs by 5 % of the RMS is not one (tolerance 1 %).
    rep = np.concatenate([base, base + 0.05 * rng.standard_normal(700)])
    assert noise_level.repeated_period(rep) == 0
    rep = np.concatenate([base, base + 0.002 * rng.standard_normal(700)])
    assert noise_level.repeated_period(rep) == 700
    # Too short to hold a Welch segment after the transient: no period.
    assert noise_level.repeated_period(np.tile(base[:100], 2)) == 0


def test_noise_level_crossing_interpolates_in_log_level():
    from porosense.ident import process_noise as estimate

    # log ratio = 2 log(sigma / 0.8): crosses 0 at 0.8.
    levels = [0.25, 0.5, 1.0, 2.0]
    logs = [2 * np.log(s / 0.8) for s in levels]
    assert abs(estimate._crossing(levels, logs) - 0.8) < 1e-12
    assert abs(estimate._slope(levels, logs) - 2.0) < 1e-12
    # Never crossing: the level closest to a ratio of 1.
    assert estimate._crossing([0.5, 1.0], [-2.0, -0.5]) == 1.0


@pytest.mark.parametrize("periodic", [True, False])
def test_identify_says_how_the_noise_level_was_decided(tmp_path, capsys, periodic):
    from porosense.cli import main

    simulate, noise, gain, rng = _system(5)
    paths = []
    for k in range(3):
        base = gain * rng.standard_normal(600)
        u = np.tile(base, 2) if periodic else gain * rng.standard_normal(1200)
        y = simulate(u, noise, 0.01)
        p = tmp_path / f"rec{k}.csv"
        p.write_text(
            "t,u,y\n"
            + "\n".join(f"{i * 0.01!r},{a!r},{b!r}" for i, (a, b) in enumerate(zip(u.tolist(), y.tolist())))
            + "\n"
        )
        paths.append(str(p))
    report = tmp_path / "report.json"
    rc = main(
        [
            "identify",
            "--data",
            *paths,
            "--input",
            "u",
            "--output",
            "y",
            "--ts",
            "0.01",
            "--structure",
            "wh",
            "--poles",
            "2",
            "--zeros",
            "1",
            "--breakpoints",
            "6",
            "--max-iter",
            "15",
            "--starts",
            "1",
            "--smoothness",
            "0",
            "--process-noise",
            "--out",
            str(tmp_path / "m.json"),
            "--json-out",
            str(report),
        ]
    )
    captured = capsys.readouterr()
    out = captured.out
    assert rc == 0, captured.err
    rep = json.loads(report.read_text())["results"][0]
    line = [s for s in out.splitlines() if s.startswith("process noise:")]
    assert len(line) == 1, out
    if periodic:
        assert "measured from 2 recording(s) repeat their input (period 600 samples)" in line[0]
        assert rep["process_noise"]["method"] == "repeated periods"
    else:
        # The mean-only fit cannot tell the level; its OE member may validate better and be kept.
        assert "not identifiable" in line[0] or "output-error fit validated better" in line[0]
        assert rep["process_noise"] is None


def test_search_keeps_the_measured_noise_model_when_its_oe_member_is_within_the_noise():
    """The order search scores a process-noise model and its output-error member on validation
    data that carry the same noise. With the level measured from periods, the noise-aware model
    is kept unless its member validates better by more than one standard error of the fit."""
    tasks = importlib.import_module("porosense.ident.tasks")

    us, ys, _ = _periodic_records(1)
    us = [u[:, None] for u in us]
    model = ident.WienerHammerstein(
        n_poles=2, n_zeros=1, n_breakpoints=10, skip=SKIP, starts=1, max_nfev=40, process_noise=True
    ).fit(u=us, y=ys, ts=1.0)
    assert model.info["process_noise"]["method"] == "repeated periods"
    # Scored on the estimation records: both members fit them alike.
    data = _search_data(us, ys, (us, ys, [SKIP] * len(ys)))
    members = [tasks.score("wh", 2, 1, m, data) for m in [model] + model.alternative_models()]
    top = max(members, key=lambda c: c.score("fit"))
    tol = ident.tie_tolerance(top, "fit")
    gap = top.score("fit") - members[0].score("fit")
    print(f"noise-aware {members[0].score('fit'):.3f} %, best member {top.score('fit'):.3f} %, tie {tol:.3f} points")
    # Measured (seed 1): an OE member fits 0.10 points better, within the 0.35-point tie.
    assert not top.model.spec.g_noise and 0 < gap <= tol
    # AIC has no tie band: the member with the best score is taken as before. (First: a kept
    # member loses its alternatives.)
    best_aic = tasks.best_member("wh", 2, 1, copy.copy(model), data, "aic")
    assert best_aic.score("aic") == max(m.score("aic") for m in members)
    best = tasks.best_member("wh", 2, 1, model, data, "fit")
    assert best.model.spec.g_noise


def test_period_power_standard_error_matches_the_spread_over_independent_records():
    """The standard error that decides whether a model reproduces the measured period power
    (noise_level.PeriodData.measured_error, from the Welch segments of one data set) against
    the actual spread of that power over 200 independent data sets of the same system. Own
    generator: a periodic input through a random resonant filter, output plus AR(2) noise of
    random colour; 3 records x 2 periods x 1500 samples. Bound: within 25 % of the spread
    (the spread of 200 draws is itself known to about 5 %)."""
    rng = np.random.default_rng(11)
    period = 1500
    r, a = rng.uniform(0.6, 0.9), rng.uniform(0.2, 1.0)
    ar = [1.0, -2 * r * np.cos(a), r * r]
    us = [np.tile(rng.standard_normal(period), 2)[:, None] for _ in range(3)]
    clean = [lfilter([1.0, 0.5], [1.0, -0.7], u[:, 0]) for u in us]

    def data_set():
        ys = [c + 0.3 * lfilter([1.0], ar, rng.standard_normal(len(c))) for c in clean]
        return noise_level.PeriodData(us, ys, skip=SKIP)

    first = data_set()
    used, width = first.bands.used, np.diff(first.bands.edges)[first.bands.used]
    powers, errors = [], []
    for _ in range(200):
        d = data_set()
        powers.append(float(d.measured[used] @ width))
        errors.append(d.measured_error)
    spread = np.std(powers, ddof=1) / np.mean(powers)
    print(
        f"relative standard error: from segments {np.mean(errors):.4f} (median {np.median(errors):.4f}), "
        f"spread over data sets {spread:.4f}"
    )
    assert abs(np.mean(errors) / spread - 1) < 0.25


def test_a_noise_model_the_period_differences_refute_is_rejected_and_the_oe_fit_kept(monkeypatch, tmp_path):
    """When no refined build reproduces the measured period power (every one beyond its
    bound; here forced by a zero bound), the process-noise fit is refuted by the data: the model
    keeps the output-error fit (a vanishing noise: the same output), says so, and the search
    does not prefer it over its output-error member."""
    est = importlib.import_module("porosense.ident.process_noise")
    monkeypatch.setattr(noise_level, "CONSISTENCY_Z", 0.0)
    monkeypatch.setattr(est, "PERIOD_TOLERANCE", 0.0)
    us, ys, _ = _periodic_records(0)
    us = [u[:, None] for u in us]
    m = ident.WienerHammerstein(
        n_poles=2, n_zeros=1, n_breakpoints=8, skip=SKIP, starts=1, max_nfev=20, process_noise=True
    ).fit(u=us, y=ys, ts=1.0)
    info = m.info["process_noise"]
    assert info["method"] == "repeated periods, rejected" and not info["consistent"]
    assert info["power_ratio_error"] > 0 and "rejected" in m.info["build"]
    oe = m.alternative_models()[0]
    assert not oe.spec.g_noise
    np.testing.assert_allclose(m.predict(u=us[0]), oe.predict(u=us[0]), rtol=1e-9, atol=1e-9)
    line = importlib.import_module("porosense.cli.identify")._process_noise_line(m)
    assert line.startswith("process noise: rejected") and "0.00 standard errors" in line  # the bound in force
    tasks = importlib.import_module("porosense.ident.tasks")
    data = _search_data(us, ys, (us, ys, [SKIP] * 2))
    best = tasks.best_member("wh", 2, 1, m, data, "fit")
    assert not best.model.spec.g_noise  # the search keeps an output-error member, not the refuted noise model
    assert best.score("fit") == max(
        c.score("fit") for c in [tasks.score("wh", 2, 1, x, data) for x in [m] + m.alternative_models()]
    )


def test_search_with_process_noise_orders_by_the_nonparametric_bla():
    """With at least 4 realisations that repeat their input, the search with process noise
    ranks orders by the nonparametric BLA (validation data carrying the noise cannot): linear
    orders by their number of parameters until one is not refuted at 1 %, the nonlinear
    structures at that order only, candidates at refuted orders never selected. Own generator
    (random WH, AR(1) process noise at 0.3-0.7 of g's input spread), 5 + 1 records x 2 periods."""
    us, ys, _ = _periodic_records(4, n_records=6, period=600)
    us = [u[:, None] for u in us]
    grid = [(s, p, z) for s in ("linear", "wh") for p in (1, 2, 3, 4) for z in range(p)]
    res = ident.search(
        u=us[:5],
        y=ys[:5],
        ts=0.02,
        validation=(us[5:], ys[5:]),
        validation_skip=SKIP,
        skip=SKIP,
        grid=grid,
        n_breakpoints=6,
        max_nfev=20,
        starts=1,
        progress=False,
        criterion="fit",
        staged=True,
        process_noise=True,
    )
    print(res)
    assert "order from the nonparametric BLA of 5 realisations" in res.rule
    order = {(c.n_poles, c.n_zeros) for c in res.candidates if c.structure == "wh"}
    assert len(order) == 1
    ((p, z),) = order
    linear = {(c.n_poles, c.n_zeros): c for c in res.candidates if c.structure == "linear"}
    # Every linear order with fewer parameters was fitted and refuted; none with more was fitted.
    assert all(linear[o].refuted for o in linear if sum(o) < p + z)
    assert not linear[(p, z)].refuted and max(sum(o) for o in linear) == p + z
    assert not res.best.refuted and (res.best.n_poles, res.best.n_zeros) not in {
        o for o, c in linear.items() if c.refuted
    }


def test_records_too_short_for_the_colour_diagnostic_still_fit():
    """One record of two 320-sample periods repeats its input but holds a single Welch segment
    per difference: the level is still measured, and the colour diagnostic is left out (None)
    instead of failing the fit; the identify line then omits it."""
    us, ys, _ = _periodic_records(3, n_records=1, period=320)
    m = ident.WienerHammerstein(
        n_poles=2, n_zeros=1, n_breakpoints=6, skip=SKIP, starts=1, max_nfev=10, process_noise=True
    ).fit(u=[u[:, None] for u in us], y=ys, ts=1.0)
    info = m.info["process_noise"]
    assert info["method"].startswith("repeated periods") and info["colour"] is None
    line = importlib.import_module("porosense.cli.identify")._process_noise_line(m)
    assert line.startswith("process noise") and "colour" not in line


@pytest.mark.slow
def test_a_deconvolution_the_records_do_not_determine_keeps_the_output_error_fit(monkeypatch):
    """Builds whose expected outputs the records cannot tell apart can still disagree on the
    noise-free system they deconvolve. When they disagree by more than the chosen build moved
    from its output-error fit, the correction is not determined and the OE fit stays
    (process_noise.deconvolution_spread).

    Measured on the independent generator, seeds 0-7 (the records of the level test above):
    noise-free test RMSE of the chosen noise-aware build / its OE fit 0.48, 0.50, 0.74, 1.42,
    0.88, 1.58, 0.60, 2.35; correction / spread 2.8, 1.13, 4.3, 5.3, 2.1, 1.00, 2.2, 3.2 (after
    the split of the estimation code, seeds 0-5: 0.49, 0.50, 0.73, 1.42, 0.89, 1.56 and 2.64,
    1.92, 4.31, 5.28, 1.82, 1.0015: seed 5's correction 0.2210 against a spread of 0.2206, which
    the margin of one standard error of the norm, 0.8 % here, counts as equal): the
    check fires on seed 5 only (an equally good build sits on the OE fit), where the kept model
    tests at 1.00 x OE instead of 1.58; it keeps all five gains, and it misses seeds 3 and 7
    (their tied builds are two refinements of one route and agree). On the measured WH
    benchmark it keeps realisations 0-4 (test 16.6 mV at 6p5z) and discards 5-9 (65.7 mV, worse
    than linear 39.1 mV: its OE fit, 35.4 mV, stays; porosense bench ident --only builds --realisations 5-9 --order 6,5 --starts 2).
    The suite runs seeds 0-5 (cost); ``DECONVOLUTION_SEEDS=8`` runs all eight. Bounds: no gain
    discarded, the check fires at least once, and never on a model it improves.

    Those figures are without the prior on the maps' slope changes (porosense.ident.pwl_prior).
    With it, seeds 0-7: 0.47, 0.41, 0.62, 1.23, 0.53, 0.54, 0.51, 2.54, correction / spread 7.2,
    4.4, 11.3, 7.3, >1e9, 1.71, 3.95, 2.38: seed 5 is a gain and the check fires on none, so it is
    exercised on seed 5 fitted without the prior (bend_prior=False, the figures above). Bound on
    the prior: at least 5 of seeds 0-5 gain (4 without it).
    """
    estimate = importlib.import_module("porosense.ident.process_noise")
    real = estimate.deconvolution_spread
    seen = {}

    def spy(chosen, parent, tied, us, skip):
        seen["chosen"] = chosen
        return real(chosen, parent, tied, us, skip)

    monkeypatch.setattr(estimate, "deconvolution_spread", spy)
    rows = []
    cases = [(seed, True) for seed in range(int(os.environ.get("DECONVOLUTION_SEEDS", "6")))] + [(5, False)]
    for seed, prior in cases:
        us, ys, _ = _periodic_records(seed)
        m = ident.WienerHammerstein(
            n_poles=2,
            n_zeros=1,
            n_breakpoints=10,
            skip=SKIP,
            starts=1,
            max_nfev=40,
            process_noise=True,
            bend_prior=prior,
        ).fit(u=[u[:, None] for u in us], y=ys, ts=1.0)
        simulate, _, gain, rng = _system(seed)
        ut = gain * rng.standard_normal(N)
        yt = simulate(ut, 0.0)
        c = seen.pop("chosen")
        unguarded = Chain(c.spec, c.theta).simulate(ut[:, None] / m.u_scale, expected=False) * m.y_std + m.y_mean
        oe = m.alternative_models()[0]
        e_oe = ident.rmse(yt[SKIP:], oe.predict(u=ut[:, None])[SKIP:])
        info = m.info["process_noise"]
        d = info["deconvolution"]
        rows.append(
            {
                "seed": seed,
                "prior": prior,
                "determined": d["determined"],
                "unguarded": ident.rmse(yt[SKIP:], unguarded[SKIP:]) / e_oe,
                "kept": ident.rmse(yt[SKIP:], m.predict(u=ut[:, None])[SKIP:]) / e_oe,
            }
        )
        print(
            f"seed {seed}{'' if prior else ' without the prior'}: {info['method']}, correction / spread {d['correction'] / max(d['spread'], 1e-12):.2f} "
            f"({d['tied_builds']} tied builds); noise-free test RMSE / OE: chosen build {rows[-1]['unguarded']:.2f}, "
            f"kept {rows[-1]['kept']:.2f}"
        )
        if not d["determined"]:
            assert info["method"] == "repeated periods, undetermined" and rows[-1]["kept"] == pytest.approx(
                1.0, abs=0.01
            )
            line = importlib.import_module("porosense.cli.identify")._process_noise_line(m)
            assert "do not determine the noise-free system" in line and "output-error fit is kept" in line
    assert all(r["determined"] for r in rows if r["unguarded"] < 1.0)  # no gain discarded
    fired = [r for r in rows if not r["determined"]]
    assert fired and all(r["unguarded"] > 1.0 for r in fired)  # it fires, and only on losses
    gains = [r["kept"] < 1.0 for r in rows if r["prior"] and r["seed"] < 6]
    assert sum(gains) >= 5, rows
