"""Fixed-point design and the bit-exact reference of the firmware estimator.

    result = quantize(structure, recordings=[rec1, rec2])   # -> QuantResult(.blob, .report)
    data = result.blob.to_bytes()                            # what MODEL_BEGIN/CHUNK send
    est = FixedPointEstimator(ModelBlob.from_bytes(data))
    y, flags = est.run(dr_centi)                             # int16 (N, 3), uint8 (N,)

Formats: firmware/lib/core/MODEL_FORMAT.md.
"""

from porosense.protocol.model_blob import FORMAT_VERSION, MAX_BLOB_LEN, ModelBlob
from porosense.quant.cheader import c_header
from porosense.quant.design import orders_that_fit
from porosense.quant.fixed import FixedPointEstimator
from porosense.quant.quantize import QuantResult, evaluate, quantize
from porosense.quant.report import QuantReport, RecordingFit, fit_percent

__all__ = [
    "FORMAT_VERSION",
    "MAX_BLOB_LEN",
    "FixedPointEstimator",
    "ModelBlob",
    "QuantReport",
    "QuantResult",
    "RecordingFit",
    "c_header",
    "evaluate",
    "fit_percent",
    "orders_that_fit",
    "quantize",
]
