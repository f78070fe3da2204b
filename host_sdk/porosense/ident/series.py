"""Load compensation as the paper did it: one more transfer function in series after a model.

A model identified without load loses fit under a load (the paper's contractor: 82.6 % without,
61.7 % under 500 g). The paper compensates with a linear transfer function identified for the
load condition and placed after the no-load model: its input is the no-load model's simulated
output, its output the measured output under the load (74.07 % under 500 g). The no-load model
is kept as it is; only the series block is fitted (output error, simulated from rest).

File format: ``{"format": "porosense.ident.series", "version": 1, "condition": text, "nominal":
<model dict>, "series": <model dict>}``; ``porosense predict`` and ``compare`` read it as any
model file.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from porosense.data.model_file import SERIES_FORMAT
from porosense.errors import InputError, ModelError
from porosense.files import write_text
from porosense.ident.models import FORMAT_VERSION as MODEL_VERSION
from porosense.ident.models import Model, as_recordings, make_model

FORMAT = SERIES_FORMAT
FORMAT_VERSION = 1


class SeriesModel:
    """A nominal model followed by a linear transfer function identified for one condition.

    Parameters
    ----------
    nominal : Model
        The model identified without the condition (one output).
    series : Model
        Linear model from the nominal output (its one input, the nominal output's unit) to the
        measured output under the condition.
    condition : str
        What the series block compensates (free text, e.g. ``"500 g"``).
    """

    kind = "series"

    def __init__(self, nominal: Model, series: Model, condition: str = ""):
        self.nominal, self.series, self.condition = nominal, series, str(condition)

    @property
    def inputs(self):
        return tuple(self.nominal.inputs)

    @property
    def output(self):
        return self.nominal.output

    @property
    def ts(self):
        return self.nominal.ts

    @property
    def n_poles(self):
        return self.series.n_poles

    @property
    def n_zeros(self):
        return self.series.n_zeros

    def predict(self, *, u) -> np.ndarray:
        """Simulate from rest.

        Parameters
        ----------
        u : array_like, shape (N, n_inputs) or (N,)
            The nominal model's inputs, data units.

        Returns
        -------
        ndarray, shape (N,)
            Compensated output, output units.
        """
        return self.series.predict(u=self.nominal.predict(u=u)[:, None])

    def score(self, *, u, y) -> dict:
        """Per recording fit and RMS (%) of the compensated output simulated from rest.

        Parameters
        ----------
        u, y : array or list of arrays
            Inputs (N, n_inputs) and measured output (N,) per recording, data units.

        Returns
        -------
        dict
            ``fit``: NRMSE fit per recording, %; ``rms``: RMS error per recording, % of max |y|.
        """
        from porosense.dsp.metrics import fit_percent, rms_percent

        us, ys = as_recordings(u, y)
        preds = [self.predict(u=x) for x in us]
        return {
            "fit": [fit_percent(v, p) for v, p in zip(ys, preds)],
            "rms": [rms_percent(v, p) for v, p in zip(ys, preds)],
        }

    def to_structure(self):
        raise ModelError(
            "a series-compensated model runs on the host (porosense predict); quantize its nominal model for the board"
        )

    def to_dict(self) -> dict:
        """The file's content in plain JSON types."""
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "condition": self.condition,
            "nominal": self.nominal.to_dict(),
            "series": self.series.to_dict(),
        }

    @classmethod
    def from_dict(cls, d: dict) -> SeriesModel:
        """A series model from :meth:`to_dict` output (ModelError when malformed)."""
        try:
            parts = [d["nominal"], d["series"]]
            bad = [p.get("version") for p in parts if p.get("version") != MODEL_VERSION]
            if bad:
                raise ModelError(f"series model: inner model format version {bad[0]}, this build reads {MODEL_VERSION}")
            nominal, series = (Model.from_dict(p) for p in parts)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise ModelError(f"malformed series model ({exc})") from exc
        if series.kind != "linear" or len(series.inputs) != 1:
            raise ModelError("series model: the series block must be a linear model of one input")
        return cls(nominal, series, d.get("condition", ""))

    def save(self, path) -> Path:
        """Write the file (whole or not at all); returns its path."""
        path = Path(path)
        write_text(path, json.dumps(self.to_dict(), indent=1, allow_nan=False))
        return path

    def __repr__(self) -> str:
        cond = f" for {self.condition}" if self.condition else ""
        return f"SeriesModel({self.nominal!r} then linear {self.n_poles}p{self.n_zeros}z{cond})"


def fit_series(nominal, u, y, *, ts: float | None = None, order=(2, 1), condition: str = "") -> SeriesModel:
    """Identify the series transfer function for a condition after ``nominal`` (the paper's load
    compensation).

    Parameters
    ----------
    nominal : Model
        A fitted single-output model identified without the condition.
    u, y : array or list of arrays
        Inputs (N, n_inputs) and measured output (N,) under the condition, one recording or a list.
    ts : float or None
        Sample period, s (None: the nominal model's).
    order : (int, int)
        Poles and zeros of the series block (default 2 and 1, the paper's 3-DoF order).
    condition : str
        What the block compensates, stored in the file.

    Returns
    -------
    SeriesModel
        The nominal model followed by the fitted block.

    Raises
    ------
    InputError
        A model with several outputs or one that is not an identified model, or a period other
        than the nominal model's.
    """
    if not isinstance(nominal, Model):
        raise InputError(
            f"the nominal model must be one identified model of one output (porosense identify), not {nominal.kind}"
        )
    if ts is not None and abs(ts - nominal.ts) > 0.01 * nominal.ts:
        raise InputError(
            f"the records' sample period {ts * 1000:.4g} ms differs from the nominal model's {nominal.ts * 1000:.4g} ms"
        )
    us, ys = as_recordings(u, y)
    base = [nominal.predict(u=x)[:, None] for x in us]
    if not all(np.all(np.isfinite(b)) for b in base):
        raise ModelError("the nominal model's simulation diverges on the records")
    poles, zeros = int(order[0]), int(order[1])
    block = make_model("linear", n_poles=poles, n_zeros=zeros)
    block.fit(
        u=base,
        y=ys,
        ts=nominal.ts,
        inputs=[f"{nominal.output}_nominal"],
        output=nominal.output,
        output_unit=nominal.output_unit,
    )
    return SeriesModel(nominal, block, condition)
