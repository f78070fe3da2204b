"""Quantization: fixed-point fit against float and data, overflow, the EEPROM size limit."""

import numpy as np
import pytest
from scipy import signal

from porosense.errors import ModelError
from porosense.protocol.model_blob import MAX_BLOB_LEN
from porosense.quant import FixedPointEstimator, quantize
from porosense.quant.random_models import random_structure, step_inputs
from porosense.structure import Branch, EstimatorStructure, OutputChain, SOSCascade

LOSS_BOUND = 0.5  # fit points the fixed-point model may lose against the float one (issue 7)


def _noisy(structure, u, rng):
    y = structure.simulate(u)
    return y + rng.normal(0, 0.05 * np.std(y, axis=0), y.shape)


@pytest.mark.parametrize("kind", ["linear", "hammerstein", "wiener", "wh"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_models_lose_at_most_half_a_point(kind, seed):
    rng = np.random.default_rng(seed)
    s = random_structure(rng, 1, 1, h1_poles=int(rng.integers(2, 7)), h2_poles=2, kind=kind)
    est_u, val_u = step_inputs(rng, 6000), step_inputs(rng, 6000)
    r = quantize(
        s, recordings=[("estimation", est_u, _noisy(s, est_u, rng)), ("validation", val_u, _noisy(s, val_u, rng))]
    )
    for f in r.report.fits:
        assert abs(f.loss_points) <= LOSS_BOUND, str(r.report)
        assert f.saturated_samples == 0
        assert f.fit_fixed_vs_float >= 98.0


def test_five_poles_at_0999():
    """Poles piled up near z = 1: delta form and 32-bit states keep the DC gain and dynamics."""
    p = np.full(5, 0.999)
    k = float(np.prod(1 - p)) * -0.2
    h1 = SOSCascade(signal.zpk2sos(np.zeros(5), p, k, pairing="nearest"))
    s = EstimatorStructure(inputs=("dR_0",), outputs=(OutputChain("y", (Branch(0, h1),)),), ts=0.02)
    rng = np.random.default_rng(4)
    u = step_inputs(rng, 30000, hold=5000)
    r = quantize(s, recordings=[("slow", u, _noisy(s, u, rng))])
    f = r.report.fits[0]
    assert r.report.delta_sections >= 2
    assert abs(f.loss_points) <= LOSS_BOUND and f.saturated_samples == 0
    assert f.fit_fixed_vs_float >= 99.0


def test_no_overflow_anywhere_in_the_input_range():
    """The l1 scaling guarantee: inputs held at the range ends never saturate."""
    s = random_structure(np.random.default_rng(9), 2, 2, h1_poles=4, h2_poles=2, kind="wh")
    r = quantize(s, input_range=(-90.0, 20.0))
    n = 20000
    u = np.zeros((n, 3), dtype=np.int64)
    u[:, 0] = np.where((np.arange(n) // 4000) % 2, -9000, 2000)
    u[:, 1] = np.where((np.arange(n) // 2500) % 2, 2000, -9000)
    _, flags = FixedPointEstimator(r.blob).run(u)
    assert int(np.count_nonzero(flags)) == 0


def test_data_outside_the_range_is_reported_as_saturation():
    s = random_structure(np.random.default_rng(10), 1, 1, h1_poles=2, h2_poles=2, kind="wh")
    u = step_inputs(np.random.default_rng(10), 4000, lo=-85, hi=5)
    with pytest.raises(ModelError, match="saturates on wide"):  # refused unless forced
        quantize(s, recordings=[("wide", u, None)], input_range=(-5.0, 5.0))
    r = quantize(s, recordings=[("wide", u, None)], input_range=(-5.0, 5.0), force=True)
    assert r.report.saturated_samples > 0
    assert any("saturates on wide" in n for n in r.report.notes)


def _three_dof(h1_poles, h2_poles, breakpoints, seed=1):
    return random_structure(
        np.random.default_rng(seed), 3, 3, h1_poles=h1_poles, h2_poles=h2_poles, breakpoints=breakpoints, kind="wh"
    )


def test_worst_case_three_dof_is_refused_with_the_orders_that_fit():
    with pytest.raises(ModelError) as err:
        quantize(_three_dof(10, 10, 16), input_range=(-100, 100))
    msg = str(err.value)
    assert "bytes too large" in msg and f"{MAX_BLOB_LEN}-byte EEPROM" in msg and "orders that fit: H1 <=" in msg
    excess = int(msg.split(" bytes, ")[1].split(" ")[0])
    assert excess > 0


def test_three_dof_within_the_suggested_orders_fits():
    with pytest.raises(ModelError) as err:
        quantize(_three_dof(10, 10, 16), input_range=(-100, 100))
    first = str(err.value).split("orders that fit: ")[1].split(";")[0]  # "H1 <= a poles, H2 <= b poles, c breakpoints"
    nums = [int(t) for t in first.replace(",", " ").split() if t.isdigit()]
    r = quantize(_three_dof(*nums), input_range=(-100, 100))
    assert r.blob.length <= MAX_BLOB_LEN and r.blob.n_outputs == 3 and r.blob.n_inputs == 3


@pytest.fixture(scope="module")
def paper_recordings():
    from porosense.sim import run_experiment

    names = ["staircase", "step_10", "step_60", "step_20", "step_40"]
    return {e: run_experiment("contractor", e, rate_hz=50, seed=i) for i, e in enumerate(names)}


@pytest.mark.slow
@pytest.mark.parametrize(
    "kind",
    [
        "Linear",
        "WienerHammerstein",
        "Hammerstein",
        "Wiener",
    ],
)
def test_paper_style_models_identified_from_simulated_experiments(paper_recordings, kind):
    """Contractor: estimation staircase, -10, -60 kPa; validation -20, -40 kPa (the paper's split);
    all four structures, in CI as elsewhere. The bound is the requirement's: at most 0.5 fit points
    lost on every validation recording; on the estimation recordings the loss is printed."""
    from porosense import ident

    recs = paper_recordings
    names = list(recs)
    est = names[:3]
    m = (
        getattr(ident, kind)(n_poles=3, n_zeros=1)
        if kind == "Linear"
        else getattr(ident, kind)(n_poles=3, n_zeros=1, n_breakpoints=10)
    )
    m.fit(
        u=[recs[e]["dR_0"][:, None] for e in est],
        y=[recs[e]["strain_0"] for e in est],
        ts=0.02,
        inputs=["dR_0"],
        output="strain_0",
    )
    r = quantize(m.to_structure(), recordings=[recs[e] for e in names])
    for f in r.report.fits:
        print(f"{kind} {f.recording}: fixed-point loss {f.loss_points:+.3f} fit points")
        if f.recording not in est:
            assert abs(f.loss_points) <= LOSS_BOUND, f"{kind}: {r.report}"
        assert f.saturated_samples == 0
