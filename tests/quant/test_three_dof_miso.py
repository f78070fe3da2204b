"""A 3-DoF MISO model as the demo identifies it (inputs dR/100, declared in the structure): the fixed-point
estimate on the device's own inputs stays within 0.5 fit points of the float model on the same
inputs, and the report measures exactly what the device computes, noise included."""

import numpy as np
import pytest

from porosense.protocol.model_blob import MAX_BLOB_LEN
from porosense.quant import FixedPointEstimator, fit_percent, quantize
from porosense.quant.quantize import device_inputs
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade

LOSS_BOUND = 0.5  # fit points (issues 7 and 9)
LSB = 1e-4  # dR fraction per device LSB (0.01 %)
SENSOR_NOISE_LSB = 4.0  # RMS of the simulated board's dR noise (0.04 %)


def _pwl(x, y):
    return PiecewiseLinear(np.array(x), np.array(y))


def _sos(*rows):
    return SOSCascade(np.array(rows, dtype=float))


def _hammerstein(name, tables, numerators, poles, offset):
    branches = tuple(
        Branch(i, _sos([b0, b1, 0, 1, -(p1 + p2), p1 * p2]), _pwl(*t))
        for i, (t, (b0, b1), (p1, p2)) in enumerate(zip(tables, numerators, poles))
    )
    return OutputChain(name, branches, offset=offset)


def three_dof_structure() -> EstimatorStructure:
    """theta_x, theta_y: Hammerstein, 2 poles 1 zero per input; dz: Wiener-Hammerstein with one
    pole, steep tables near dR = 0 and negative real poles (a large gain at high frequency), the
    shape that made the demo's on-device dz noisy."""
    xs = [-0.64, -0.56, -0.39, -0.14, -0.11, -0.075, -0.037, 0.0, 0.013, 0.065]
    ys = [-1.08, -0.84, -0.52, -0.185, -0.16, -0.105, -0.046, 0.026, 0.029, -0.01]
    theta_x = _hammerstein(
        "theta_x",
        [(xs, ys)] * 3,
        [(-47.76, 44.46), (25.16, -23.36), (22.55, -20.99)],
        [(0.62, 0.74), (0.63, 0.75), (0.65, 0.84)],
        -0.035,
    )
    theta_y = _hammerstein(
        "theta_y",
        [(xs, [0.9 * v for v in ys])] * 3,
        [(30.1, -28.4), (-22.75, 21.23), (21.81, -20.33)],
        [(0.70, 0.76), (0.68, 0.81), (0.66, 0.86)],
        -0.017,
    )
    dz_tables = [
        (
            [-0.5956, -0.5135, -0.3507, -0.149, -0.1249, -0.0779, -0.0557, -0.0234, 0.0034, 0.0551],
            [-1.26, -0.9691, -0.5827, -0.2511, -0.2055, -0.1348, -0.0939, -0.0294, 0.054, 0.028],
        ),
        (
            [-0.8371, -0.7805, -0.6401, -0.4136, -0.1626, -0.1113, -0.0879, -0.0404, 0.0003, 0.0367],
            [-1.2134, -1.3476, -0.9842, -0.6332, -0.3916, -0.366, -0.3384, -0.2905, -0.2414, 0.571],
        ),
        (
            [-0.6414, -0.5694, -0.2359, -0.1394, -0.1116, -0.0867, -0.0519, -0.0044, 0.0063, 0.0571],
            [-1.3779, -1.1275, -0.3906, -0.2661, -0.2415, -0.2078, -0.1499, -0.0587, 0.0301, -0.0709],
        ),
    ]
    dz_h1 = [(-1.8347, 0.6107), (-1.6983, -0.1906), (-2.0261, 0.661)]
    dz = OutputChain(
        "dz",
        tuple(Branch(i, _sos([b0, 0, 0, 1, a1, 0]), _pwl(*t)) for i, (t, (b0, a1)) in enumerate(zip(dz_tables, dz_h1))),
        g=_pwl(
            [0.1559, 0.3436, 0.4748, 0.5758, 0.7565, 1.0185, 1.4436, 1.8725, 2.1904, 2.9162],
            [-0.0025, -0.0091, 0.0077, 0.1619, 0.4813, 0.9552, 1.7138, 2.47, 3.0171, 4.2927],
        ),
        h2=_sos([10.3482, -9.6187, 0, 1, -0.4457, 0]),
        offset=0.0162,
    )
    return EstimatorStructure(("dR_0", "dR_1", "dR_2"), (theta_x, theta_y, dz), 0.02, input_units=("dR/100",) * 3)


def sequential_inputs(n_seg: int = 400) -> np.ndarray:
    """dR fractions (N, 3): one, two, then three contractors on (dR -0.12 to -0.28), first-order
    responses, rest in between (N = 14 n_seg)."""
    groups = [(0,), (1,), (2,), (0, 1), (1, 2), (0, 2), (0, 1, 2)]
    target = np.zeros((len(groups) * 2 * n_seg, 3))
    for k, g in enumerate(groups):
        for c in g:
            target[2 * k * n_seg : (2 * k + 1) * n_seg, c] = -0.12 - 0.16 * (k / (len(groups) - 1))
    target += 0.008  # a small positive dR at rest, where the dz tables are steepest
    u = np.zeros_like(target)
    for i in range(1, len(u)):
        u[i] = u[i - 1] + 0.08 * (target[i] - u[i - 1])
    return u


@pytest.fixture(scope="module")
def case():
    s = three_dof_structure()
    u_true = sequential_inputs()
    y = s.simulate(u_true)  # the measured outputs: the model of the true dR
    rng = np.random.default_rng(3)
    measured = device_inputs(u_true + rng.normal(0.0, SENSOR_NOISE_LSB * LSB, u_true.shape), LSB) * LSB
    return s, u_true, measured, y


def test_fixed_point_loses_at_most_half_a_point_on_device_inputs(case):
    s, _, measured, y = case
    r = quantize(s, recordings=[("sequential", measured, y)])
    assert r.blob.length <= MAX_BLOB_LEN
    assert len(r.report.fits) == 3
    for f in r.report.fits:
        assert abs(f.loss_points) <= LOSS_BOUND, str(r.report)
        assert f.fit_fixed_vs_float >= 99.0, str(r.report)
        assert f.saturated_samples == 0
    assert not any(n.startswith("inputs not on the device") for n in r.report.notes)


def test_report_is_what_the_device_computes(case):
    s, _, measured, y = case
    r = quantize(s, recordings=[("sequential", measured, y)])
    counts = np.zeros((len(measured), 3), dtype=np.int64)
    counts[:] = np.round(measured / LSB)  # the device's dr_centi: exact here
    est, _ = FixedPointEstimator(r.blob).run(counts)
    y_float = s.simulate(counts * LSB)
    for j, f in enumerate(r.report.fits):
        on_device = fit_percent(y[:, j], est[:, j] * r.blob.out_scale[j])
        assert abs(f.fit_fixed_vs_data - on_device) <= 1e-9
        assert abs(f.fit_float_vs_data - fit_percent(y[:, j], y_float[:, j])) <= 1e-9


def test_noise_free_inputs_are_flagged_and_the_noise_probe_shows_the_device_loss(case):
    """Quantized against noise-free truth (as the demo's recordings were), the fixed-point fit
    looks perfect; the report says the inputs are not device samples, and its noise probe at the
    board's noise level predicts what the device then loses on dz."""
    s, u_true, measured, y = case
    r = quantize(s, recordings=[("truth", u_true, y)], noise_lsb=SENSOR_NOISE_LSB)
    assert any(n.startswith("inputs not on the device") and "truth" in n for n in r.report.notes)
    on_device = quantize(s, recordings=[("measured", measured, y)], noise_lsb=0).report.fits
    for f, d in zip(r.report.fits, on_device):
        actual_loss = f.fit_fixed_vs_data - d.fit_fixed_vs_data
        assert abs(f.noise_loss_points - actual_loss) <= max(0.5, 0.25 * abs(actual_loss)), str(r.report)
    dz = r.report.fits[2]
    assert dz.noise_loss_points >= 1.0, str(r.report)  # the hazard is visible in the report
    assert r.report.worst_noise_loss_points == pytest.approx(max(f.noise_loss_points for f in r.report.fits))


def test_device_inputs_round_half_away_from_zero_and_saturate():
    u = np.array([[0.5, -0.5, 1.5], [-1.5, 2.49, 40000.0], [-40000.0, 0.0, -2.5]]) * LSB
    assert device_inputs(u, LSB).tolist() == [[1, -1, 2], [-2, 2, 32767], [-32768, 0, -3]]
