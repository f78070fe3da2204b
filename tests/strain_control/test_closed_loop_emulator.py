"""The board's controller on the emulator (the firmware core over the simulated contractor),
gains and model identified at 0 g from the simulator's recordings: steps under 0 and 500 g
against the TRUE strain, closed loop versus the 0 g static-map baseline (the bench's core at
CI size), a tracking trajectory, and an estimator identified under load as well.

Bounds come from measurements with a margin (figures printed with -s). Since the simulator's
sensor varies from recording to recording as real prints do (porosense.sim.variation: sensitivity,
contact-law scale, softening state, R0 drift; issue 31), a model identified on some recordings
reads another recording's strain with a bias of 1-2 % strain at 0 g, and the closed loop keeps
it (measured at seed 7: -1.06 / -2.12 / -1.35 % at targets 8 / 16 / 12 %, against 0.6 before);
the open loop on the pressure map does not see the sensor (0.14 %). The physics' floor:
a hanging load holds pore contacts open (porosense.sim.params.Piezo, load_contact_coupling), so the
0 g model under-reads the strain under 500 g by about 1.4-1.5 % strain at steady state (2.5 before
the foam carried 60 % of a hanging load and the sealed sleeve the rest, porosense.sim.params.Foam)
(porosense.sim.steady_state, independent of the controller); closed loop cannot beat that.
"""

from __future__ import annotations

import numpy as np
import pytest

from porosense.control.loadbench import HOLD_S, TARGETS, identify_setup, measure_load

# One worker runs the module: the identified setup and the loaded runs are module fixtures, and
# a worker builds its own copy of each (the module split over two workers built them twice).
pytestmark = pytest.mark.xdist_group("closed-loop-emulator")


@pytest.fixture(scope="module")
def setup():
    return identify_setup(50, seed=100)


@pytest.fixture(scope="module")
def loads(setup):
    return {L: measure_load(setup, L, TARGETS["small"], HOLD_S["small"], seed=7 + int(L)) for L in (0.0, 500.0)}


def _print(r):
    cl = ", ".join(f"{m['target']:g}: {m['steady_error']:+.2f}" for m in r["closed_loop"])
    ol = ", ".join(f"{m['target']:g}: {m['steady_error']:+.2f}" for m in r["open_loop"])
    print(
        f"{r['load_g']:g} g: closed {r['closed_steady_error']:.2f} ({cl}); open {r['open_steady_error']:.2f} ({ol}); "
        f"ratio {r['ratio']:.2f}"
    )


def test_steps_reach_the_true_strain_at_0_g(loads):
    r = loads[0.0]
    _print(r)
    for m in r["closed_loop"]:
        assert abs(m["steady_error"]) < 3.0, m  # the estimate's recording-to-recording bias (measured <= 2.12)
        # measured 42 % on the 16 -> 12 % step (a 1.4 % strain bias on a 4 % step), under 15 elsewhere
        assert m["overshoot_pct"] < 60.0, m


def test_steps_under_500_g_stay_near_the_target_and_beat_the_open_loop(loads):
    r = loads[500.0]
    _print(r)
    for m in r["closed_loop"]:
        assert abs(m["steady_error"]) < 3.5, m  # the estimate's load bias (~1.5 %) plus its recording bias
    assert r["closed_steady_error"] < 0.6 * r["open_steady_error"]
    # the controller really worked: it asked for more vacuum than the 0 g map gives
    cmd = -r["recordings"]["closed"]["cmd_kpa_0"]
    assert np.nanmax(cmd) > max(r["vacuum_open_loop_kpa"])


def test_commands_stay_within_the_regulator_limit(loads):
    for r in loads.values():
        cmd = r["recordings"]["closed"]["cmd_kpa_0"]
        assert np.nanmin(cmd) >= -60.0 - 1e-6 and np.nanmax(cmd) <= 1e-6


def test_tracking_a_trajectory(setup):
    from porosense.boards import open_board
    from porosense.control.metrics import tracking_metrics
    from porosense.control.runner import prepare_board
    from porosense.control.session import run_closed_loop

    t = np.array([0, 2, 6, 8, 12, 14, 18, 20.0])
    y = np.array([4, 4, 16, 16, 8, 8, 20, 20.0])  # ramps at 3 %/s and holds
    with open_board("emulator", seed=3) as board:
        rate, scale = prepare_board(board.device, simulated=True, model=setup.blob, gains=setup.gains)
        rec = run_closed_loop(board.device, [], rate_hz=rate, out_scale=scale, truth=board.truth, trajectory=(t, y))
    skip = rec.t < 2.0  # the first target starts from rest
    tr = tracking_metrics(rec["target_0"], rec["strain_0"], skip=skip)
    print(f"trajectory: RMS {tr.rms:.3f} % strain, peak {tr.peak:.3f} ({tr.rms_pct_of_target:.1f} % of the target)")
    assert tr.n > 0.8 * 18 * rate
    # measured 2.17 (1.02 before the sensor varied between recordings): the PI lags a 3 %/s ramp
    # by about its loop time constant, plus the estimate's bias on this recording
    assert tr.rms < 3.0


def test_closed_loop_error_under_500_g_is_the_load_bias_of_the_estimate(loads):
    """The cause of what is left: the closed loop's steady-state error per target equals, within
    1.3 % strain (measured within 0.88; 0.5 before the sensor varied between recordings), the
    floor computed from the simulator's steady state alone (a perfect loop on a perfect 0 g
    estimator), not a controller shortfall."""
    r = loads[500.0]
    diffs = [m["steady_error"] - f for m, f in zip(r["closed_loop"], r["floor"])]
    print("closed-loop error minus the physics floor per target:", [round(d, 2) for d in diffs])
    assert all(f > 1.0 for f in r["floor"])  # measured 1.39 / 1.54 / 1.49 % strain
    assert max(abs(d) for d in diffs) < 1.3


@pytest.mark.xfail(
    strict=True,
    reason="measured on the simulator of issue 31: fit 20.6 % (bound 80), the estimate settles in 7.50 s against "
    "2.24 s predicted: the FOPDT tuner leaves out the sensor's relaxation (0.7 s and 3 s modes in ln R) and the "
    "estimate's bias on this recording",
)
def test_predicted_closed_loop_step_matches_the_board(setup, loads):
    """The tuner's prediction (FOPDT loop with the board's slew and command limit) against the
    first step on the emulator at 0 g: the true strain follows it with a fit of at least 80 %
    (measured 87 %), and the estimate the board controls settles within 40 % of the predicted
    time (measured 2.66 s against 2.24 s; the foam's slow creep is what the FOPDT leaves out)."""
    from porosense.control.tuning import predict_step, settling_and_overshoot
    from porosense.ident import fit_percent

    rec = loads[0.0]["recordings"]["closed"]
    on = np.isfinite(rec["target_0"])
    t0 = float(rec.t[np.argmax(on)])
    sel = (rec.t >= t0) & (rec.t < t0 + HOLD_S["small"])
    y0 = float(np.mean(rec["strain_0"][rec.t < t0]))
    step = TARGETS["small"][0] - y0
    pred = predict_step(setup.plant, setup.gains, step, duration_s=HOLD_S["small"] - 0.02, max_vacuum_kpa=60.0)
    n = min(int(sel.sum()), len(pred.y))
    fit = fit_percent(rec["strain_0"][sel][:n] - y0, pred.y[:n])
    settle, _ = settling_and_overshoot(rec.t[sel][:n] - t0, rec["est_strain_0"][sel][:n] - y0, step)
    print(
        f"predicted vs board step: fit {fit:.1f} %, estimate settles in {settle:.2f} s (predicted {pred.settling_s:.2f} s)"
    )
    assert fit > 80.0
    assert abs(settle / pred.settling_s - 1.0) < 0.4


def test_estimator_identified_under_load_meets_a_third_of_the_open_loop_error():
    """Issue 17's goal: with an estimator identified on the paper's recordings at 0 g and under
    its 500 g load (other experiments and seeds than these runs; plant, gains and the baseline's
    static map still from 0 g), the closed loop's steady-state error against the true strain is
    at most a third of the 0 g static map's under 500 g, and under 200 g, a load the estimator
    never saw. Measured (CI size): ratio 0.17 at 500 g, 0.11 at 200 g; the price is paid at 0 g
    (closed 1.37 % against the open loop's 0.02 %), where that estimator is biased the other way."""
    setup = identify_setup(50, seed=100, model_loads=(0.0, 500.0))
    for L in (200.0, 500.0):
        r = measure_load(setup, L, TARGETS["small"], HOLD_S["small"], seed=7 + int(L))
        _print(r)
        assert r["ratio"] <= 1.0 / 3.0
