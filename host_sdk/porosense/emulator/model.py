"""The estimator of the emulated board: the bit-exact fixed-point reference of porosense.quant."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from porosense.emulator.store import MODEL_REGION_BYTES

# The model region holds the store's header as well as the blob.
STORE_HEADER_BYTES = 8


@dataclass
class LoadedModel:
    """A committed blob and its running estimator."""

    estimator: object
    n_inputs: int
    n_outputs: int
    model_id: int
    out_scale: tuple[float, float, float]

    def reset(self) -> None:
        self.estimator.reset()

    def step(self, dr_centi) -> tuple[tuple[int, int, int], int]:
        """One sample: inputs in 0.01 % (3,), estimates in model LSB (3,) and flags."""
        est, flags = self.estimator.step(np.asarray(dr_centi, dtype=np.int16))
        est = [int(v) for v in np.asarray(est).ravel()[:3]]
        est += [0] * (3 - len(est))
        return tuple(est), int(flags)


def parse_blob(blob: bytes) -> LoadedModel:
    """Validate ``blob`` like the firmware's Estimator::load and start its estimator."""
    from porosense.quant import FixedPointEstimator, ModelBlob

    parsed = ModelBlob.from_bytes(bytes(blob))
    scale = [float(s) for s in np.atleast_1d(np.asarray(parsed.out_scale, dtype=float))][:3]
    scale += [0.0] * (3 - len(scale))
    return LoadedModel(
        estimator=FixedPointEstimator(parsed),
        n_inputs=int(parsed.n_inputs),
        n_outputs=int(parsed.n_outputs),
        model_id=int(parsed.model_id) & 0xFFFFFFFF,
        out_scale=tuple(scale),
    )


def model_capacity() -> int:
    """Largest blob the store accepts (bytes): quant's figure when it gives one."""
    try:
        from porosense.quant.blob import MAX_BLOB_LEN

        return int(MAX_BLOB_LEN)
    except ImportError:
        return MODEL_REGION_BYTES - STORE_HEADER_BYTES


def supported_format_version() -> int | None:
    """The blob format version the estimator reads (None: checked at commit only)."""
    try:
        from porosense.quant.blob import FORMAT_VERSION

        return int(FORMAT_VERSION)
    except ImportError:
        return None
