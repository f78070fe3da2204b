"""Model blobs for the device tests, made by porosense.quant from small fixed structures."""

from __future__ import annotations

import numpy as np
from scipy import signal

from porosense.quant import FixedPointEstimator, ModelBlob, quantize
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade

INPUT_RANGE = (-1.0, 0.5)  # dR as a fraction (-100 % .. +50 %)
INPUT_LSB = 1e-4  # 0.01 % in fractions: the structure's inputs are dR/100


def wh_structure(n_outputs: int = 1, poles: float = 0.9) -> EstimatorStructure:
    """A Wiener-Hammerstein estimator of strain from dR: f, 2nd-order H1, g, 2nd-order H2."""
    outputs = []
    for j in range(n_outputs):
        h1 = SOSCascade(signal.zpk2sos([-0.5], [poles, 0.5 + 0.1 * j], 0.05 * (1 + j)))
        h2 = SOSCascade(signal.zpk2sos([], [0.7, 0.2], 0.24))
        f = PiecewiseLinear(np.array([-1.0, -0.5, 0.0, 0.5]), np.array([-0.8, -0.45, 0.0, 0.4]))
        g = PiecewiseLinear(np.array([-2.0, -0.5, 0.0, 1.0]), np.array([40.0, 12.0, 0.0, -5.0]))
        branches = tuple(Branch(input=i, h1=h1, f=f) for i in range(min(n_outputs, 3)))
        outputs.append(OutputChain(name=f"strain_{j}", branches=branches, g=g, h2=h2))
    inputs = tuple(f"dR_{i}" for i in range(min(n_outputs, 3)))
    return EstimatorStructure(inputs=inputs, outputs=tuple(outputs), ts=0.01, input_units=("dR/100",) * len(inputs))


def make_blob(n_outputs: int = 1, model_id: int = 0x5EED0001, poles: float = 0.9) -> bytes:
    """Blob bytes of :func:`wh_structure` quantized by porosense.quant."""
    structure = wh_structure(n_outputs, poles)
    result = quantize(structure, input_range=INPUT_RANGE, model_id=model_id)
    return result.blob.to_bytes()


def reference_run(blob: bytes, dr_centi) -> np.ndarray:
    """Estimates (N, 3) int16 of the bit-exact Python reference from rest."""
    out, _ = FixedPointEstimator(ModelBlob.from_bytes(blob)).run(np.asarray(dr_centi, dtype=np.int16))
    return np.asarray(out, dtype=np.int16)
