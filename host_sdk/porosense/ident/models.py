"""Estimator objects: Linear, Hammerstein, Wiener and WienerHammerstein (one output, MISO).

    m = WienerHammerstein(n_poles=4, n_zeros=2, n_breakpoints=10)
    m.fit(u=[U1, U2], y=[Y1, Y2], ts=0.02)     # U (N, n_inputs), Y (N,) per recording
    yhat = m.predict(u=U)                        # simulation from rest, output units
    s = m.to_structure()                         # porosense.structure.EstimatorStructure

Inside, inputs are divided by their largest magnitude and the output is standardised (the
paper's dR/100 scaling is one instance of this); the scalings are folded back into the
blocks by :meth:`to_structure`, so the structure works on the raw units of the data.
"""

from __future__ import annotations

import copy
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from porosense.errors import InputError, ModelError
from porosense.files import write_text
from porosense.ident import estimate
from porosense.ident.blocks import sos_rows
from porosense.ident.chain import Chain, ChainSpec
from porosense.ident.metrics import fit_percent, information_criteria, rms_percent
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade, input_unit_scale

FORMAT = "porosense.ident.model"
FORMAT_VERSION = 1
MAX_BREAKPOINTS = 64
MAX_INPUTS = 3


def as_recordings(u, y=None):
    """Normalise the ``u``/``y`` arguments to lists of 2-D inputs and 1-D outputs."""
    us = u if isinstance(u, (list, tuple)) else [u]
    us = [np.asarray(x, dtype=float) for x in us]
    us = [x[:, None] if x.ndim == 1 else x for x in us]
    if not us or any(x.ndim != 2 for x in us):
        raise InputError("u must be an (N, n_inputs) array or a list of them")
    if y is None:
        return us, None
    ys = y if isinstance(y, (list, tuple)) else [y]
    ys = [np.asarray(v, dtype=float).ravel() for v in ys]
    if len(ys) != len(us) or any(len(a) != len(b) for a, b in zip(us, ys)):
        raise InputError("u and y need the same number of recordings and of samples in each")
    for x, v in zip(us, ys):
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(v))):
            raise InputError("u and y must be finite (no NaN or inf)")
    return us, ys


class Model:
    """Common base: orders, fitting, prediction, conversion and storage."""

    kind = "base"

    def __init__(
        self,
        *,
        n_poles: int = 2,
        n_zeros: int = 1,
        n_breakpoints: int = 10,
        delay: int = 0,
        starts: int = 2,
        max_nfev: int = 200,
        skip: int = 0,
        smoothness: float = 0.0,
        monotone: bool = False,
        process_noise: bool = False,
    ):
        if n_poles < 0 or n_zeros < 0:
            raise InputError("n_poles and n_zeros must be >= 0")
        if not 2 <= n_breakpoints <= MAX_BREAKPOINTS:
            raise InputError(f"n_breakpoints must be 2..{MAX_BREAKPOINTS}")
        if delay < 0:
            raise InputError("delay must be >= 0 samples")
        self.n_poles, self.n_zeros, self.n_breakpoints = int(n_poles), int(n_zeros), int(n_breakpoints)
        self.delay, self.starts, self.max_nfev, self.skip = int(delay), int(starts), int(max_nfev), int(skip)
        if not smoothness >= 0:
            raise InputError("smoothness must be >= 0")
        # Regularisation of the piecewise-linear values (estimate._penalty_rows).
        self.smoothness, self.monotone = float(smoothness), bool(monotone)
        # Estimate a Gaussian noise at g's input with g (estimate.with_process_noise).
        self.process_noise = bool(process_noise)
        if self.process_noise and self.kind not in NOISE_KINDS:
            raise InputError(
                f"process noise enters before a map g: only {' and '.join(NOISE_KINDS)} models take it, not {self.kind}"
            )
        self.spec: ChainSpec | None = None
        self.theta: np.ndarray | None = None
        self.u_scale = None
        self.y_mean = 0.0
        self.y_std = 1.0
        self.ts = 1.0
        self.inputs: tuple[str, ...] = ()
        self.output = "y"
        self.info: dict = {}
        self.input_units: tuple = ()  # per input "%" or "dR/100"; None entries: undeclared
        self.output_unit: str | None = None

    # -- estimation -----------------------------------------------------------------

    def _estimate(self, us, ys, opts) -> estimate.Fit:  # pragma: no cover - abstract
        raise NotImplementedError

    def fit(
        self,
        *,
        u,
        y,
        ts: float = 1.0,
        inputs=None,
        output: str = "y",
        input_unit=None,
        output_unit: str | None = None,
        linear: Model | None = None,
    ) -> Model:
        """Estimate on the recordings ``u`` (list of (N, n_in)), ``y`` (list of (N,)); ts in s.

        ``input_unit``: what ``u`` holds, "%" (dR in %) or "dR/100" (dR as a fraction), one for
        all inputs or one per input; stored in the model file and used by the quantizer.
        ``output_unit``: free text (for example "%" of strain or "deg").
        ``linear``: the linear model of the same orders already fitted on the same data; a
        nonlinear structure starts from it instead of estimating it again.
        """
        self._linear = linear
        try:
            return self._fit(
                u=u, y=y, ts=ts, inputs=inputs, output=output, input_unit=input_unit, output_unit=output_unit
            )
        finally:
            self._linear = None

    def _start_fit(self, model):
        """The estimate.Fit of ``model`` (same data and orders as this one), or None."""
        if model is None:
            return None
        same = (
            model.theta is not None
            and model.n_poles == self.n_poles
            and model.n_zeros == self.n_zeros
            and model.delay == self.delay
            and model.skip == self.skip
            and np.array_equal(model.u_scale, self.u_scale)
            and model.y_mean == self.y_mean
            and model.y_std == self.y_std
        )
        if not same:
            raise InputError(
                f"the {model.kind} model to start from must be fitted on the same data with the same orders"
            )
        return estimate.Fit(model.spec, model.theta, model.info["sse"] / self.y_std**2)

    def _fit(self, *, u, y, ts, inputs, output, input_unit=None, output_unit=None) -> Model:
        us, ys = as_recordings(u, y)
        n_in = us[0].shape[1]
        if not 1 <= n_in <= MAX_INPUTS or any(x.shape[1] != n_in for x in us):
            raise InputError(f"every recording needs the same 1..{MAX_INPUTS} input columns")
        if min(len(v) for v in ys) < self.skip + 10:
            raise InputError(f"every recording needs at least skip + 10 = {self.skip + 10} samples")
        self.ts = float(ts)
        self.inputs = tuple(inputs) if inputs is not None else tuple(f"u{i}" for i in range(n_in))
        self.output = output
        units = [input_unit] * n_in if input_unit is None or isinstance(input_unit, str) else list(input_unit)
        if len(units) != n_in:
            raise InputError(f"input_unit: one unit or one per input ({n_in})")
        for unit in units:
            if unit is not None:
                input_unit_scale(unit)  # raises on an unknown unit
        self.input_units, self.output_unit = tuple(units), output_unit
        all_u = np.vstack(us)
        scale = np.max(np.abs(all_u), axis=0)
        self.u_scale = np.where(scale > 0, scale, 1.0)
        all_y = np.concatenate(ys)
        self.y_mean = float(np.mean(all_y))
        self.y_std = float(np.std(all_y)) or 1.0
        nus = [x / self.u_scale for x in us]
        nys = [(v - self.y_mean) / self.y_std for v in ys]
        opts = estimate.Options(
            max_nfev=self.max_nfev,
            skip=self.skip,
            starts=self.starts,
            smoothness=self.smoothness,
            monotone=self.monotone,
        )
        self.alternatives = []
        result = self._estimate(nus, nys, opts)
        self._oe_fit = None
        if self.process_noise:
            # The output-error fit stays a member (the search scores it too) and the start of
            # a WH model built from this one.
            self._oe_fit = result
            noisy = estimate.with_process_noise(result, nus, nys, opts, alternatives=self.alternatives)
            self.alternatives = [result] + list(self.alternatives)
            result = noisy
        self._set_result(result, sum(len(v) - self.skip for v in ys))
        return self

    def _set_result(self, result: estimate.Fit, n: int) -> None:
        """Take the parameters of ``result`` (normalised units) and its criteria over n samples."""
        self.spec, self.theta = result.spec, np.asarray(result.theta, dtype=float)
        sse = result.sse * self.y_std**2
        aic, bic = information_criteria(sse, n, self.n_params)
        self.info = {"sse": sse, "n_samples": n, "aic": aic, "bic": bic, "nfev": result.nfev}
        if result.build:
            self.info["build"] = result.build
        self.info.update(result.notes)

    # -- use --------------------------------------------------------------------------

    def _require_fitted(self):
        if self.theta is None:
            raise ModelError(f"{type(self).__name__} is not fitted yet")

    def predict(self, *, u, expected: bool = False) -> np.ndarray:
        """Simulate from rest; ``u`` (N, n_inputs) in the units of the data; returns (N,).

        A model with process noise (``process_noise_std`` > 0) predicts the noise-free system
        by default: g itself, the map the board runs after ``quantize``, and what a recording
        without that noise shows. ``expected=True`` gives instead the output averaged over the
        estimated noise, E[H2 g(H1 u + v)], which is what a recording carrying the same noise
        matches best (the order search scores such models this way). Other models: the same.
        """
        self._require_fitted()
        x = np.asarray(u, dtype=float)
        x = x[:, None] if x.ndim == 1 else x
        if x.shape[1] != len(self.inputs):
            raise InputError(f"expected {len(self.inputs)} input columns, got {x.shape[1]}")
        return Chain(self.spec, self.theta).simulate(x / self.u_scale, expected=expected) * self.y_std + self.y_mean

    @property
    def process_noise_std(self) -> float:
        """Standard deviation of the estimated Gaussian noise at g's input, in the units of g's
        input in :meth:`to_structure` (0 for a model without process noise)."""
        self._require_fitted()
        return Chain(self.spec, self.theta).g_sigma if self.spec.g_noise else 0.0

    def score(self, *, u, y, skip: int = 0, expected: bool = False) -> dict:
        """Per recording fit % and RMS % (docs/design.md metrics) of the output simulated from rest.

        The first ``skip`` samples of each recording are simulated but not scored;
        ``expected``: as in :meth:`predict`.
        """
        us, ys = as_recordings(u, y)
        preds = [self.predict(u=x, expected=expected)[skip:] for x in us]
        ys = [v[skip:] for v in ys]
        return {
            "fit": [fit_percent(v, p) for v, p in zip(ys, preds)],
            "rms": [rms_percent(v, p) for v, p in zip(ys, preds)],
        }

    @property
    def n_params(self) -> int:
        """Free parameters (0 before fitting)."""
        return self.spec.n_params if self.spec else 0

    @property
    def aic(self) -> float:
        return self.info.get("aic", float("nan"))

    @property
    def bic(self) -> float:
        return self.info.get("bic", float("nan"))

    def alternative_models(self) -> list:
        """The other members of this fit, as models: for WH the other build's refinement and the
        starting models (WH models with identity blocks, equal to the Wiener / Hammerstein
        model each came from); with process noise also the output-error fit it was refined
        from. The order search scores them too and keeps the best by its selection rule."""
        self._require_fitted()
        out = []
        for fit in getattr(self, "alternatives", []):
            m = copy.copy(self)
            m.alternatives, m._oe_fit, m.process_noise = [], None, fit.spec.g_noise
            m._set_result(fit, self.info["n_samples"])
            out.append(m)
        return out

    # -- conversion -------------------------------------------------------------------

    def to_structure(self) -> EstimatorStructure:
        """The float estimator structure (raw data units) that quant and the firmware run."""
        self._require_fitted()
        return EstimatorStructure(
            inputs=self.inputs,
            outputs=(self.output_chain(),),
            ts=self.ts,
            meta={
                "kind": self.kind,
                "n_poles": self.n_poles,
                "n_zeros": self.n_zeros,
                **({"process_noise_std": self.process_noise_std} if self.spec.g_noise else {}),
            },
            **self._units(),
        )

    def _units(self) -> dict:
        """Units and identification peaks of the inputs, for EstimatorStructure."""
        n = len(self.inputs)
        units = tuple(self.input_units) if len(self.input_units) == n else (None,) * n
        return {
            "input_units": units,
            "output_units": (self.output_unit,),
            "input_peak": tuple(float(v) for v in self.u_scale),
        }

    def output_chain(self) -> OutputChain:
        """This model as one :class:`OutputChain` with the scalings folded into the blocks."""
        self._require_fitted()
        c = Chain(self.spec, self.theta)
        out_gain_on_h1 = c.g is None and c.h2 is None
        branches = []
        for i in range(self.spec.n_inputs):
            b, den, _ = c.h1[i]
            b = np.array(b, dtype=float)
            f = None
            if c.f[i] is not None:
                f = PiecewiseLinear(c.f[i][0] * self.u_scale[i], np.array(c.f[i][1], dtype=float))
            else:
                b = b / self.u_scale[i]
            if out_gain_on_h1:
                b = b * self.y_std
            branches.append(Branch(input=i, h1=SOSCascade(sos_rows(b, den)), f=f, delay=self.spec.delay))
        g = h2 = None
        if c.g is not None:
            gy = np.array(c.g[1], dtype=float) * (1.0 if c.h2 else self.y_std)
            g = PiecewiseLinear(np.array(c.g[0], dtype=float), gy)
        if c.h2 is not None:
            b, den, _ = c.h2
            h2 = SOSCascade(sos_rows(np.array(b, dtype=float) * self.y_std, den))
        return OutputChain(
            name=self.output, branches=tuple(branches), g=g, h2=h2, offset=c.offset * self.y_std + self.y_mean
        )

    def linear_blocks(self) -> dict:
        """python-control TransferFunction of each linear block (``h1[i]``, ``h2``), dt = ts.

        In the structure's units (the scalings folded in as :meth:`to_structure` does).
        """
        import control

        out = self.output_chain()
        blocks = {}
        for br in out.branches:
            b, a = br.h1.to_tf()
            blocks[f"h1[{self.inputs[br.input]}]"] = _tf(control, b, a, self.ts, br.delay)
        if out.h2 is not None:
            b, a = out.h2.to_tf()
            blocks["h2"] = _tf(control, b, a, self.ts, 0)
        return blocks

    def c_header(self, name: str | None = None) -> str:
        """A C header with the float coefficients of :meth:`to_structure`."""
        from porosense.ident.export import c_header

        return c_header(self.to_structure(), name or f"porosense_{self.output}")

    # -- storage ----------------------------------------------------------------------

    def to_dict(self) -> dict:
        """Plain JSON types; floats survive json.dumps/json.loads exactly (shortest repr)."""
        self._require_fitted()
        return {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "kind": self.kind,
            "orders": {
                "n_poles": self.n_poles,
                "n_zeros": self.n_zeros,
                "n_breakpoints": self.n_breakpoints,
                "delay": self.delay,
            },
            "options": {
                "starts": self.starts,
                "max_nfev": self.max_nfev,
                "skip": self.skip,
                **({"smoothness": self.smoothness} if self.smoothness else {}),
                **({"monotone": True} if self.monotone else {}),
                **({"process_noise": True} if self.process_noise else {}),
            },
            "spec": asdict(self.spec),
            "theta": [float(v) for v in self.theta],
            "scaling": {"u_scale": [float(v) for v in self.u_scale], "y_mean": self.y_mean, "y_std": self.y_std},
            "ts": self.ts,
            "inputs": list(self.inputs),
            "output": self.output,
            "signals": self._signals(),
            "info": {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in self.info.items()},
        }

    @classmethod
    def from_dict(cls, d: dict) -> Model:
        kind = d.get("kind")
        klass = KINDS.get(kind)
        if klass is None:
            raise ModelError(f"unknown model kind {kind!r}")
        m = klass(**d["orders"], **d["options"])
        m.spec = ChainSpec(**d["spec"])
        m.theta = np.array(d["theta"], dtype=float)
        if len(m.theta) != m.spec.n_params:
            raise ModelError("model file: parameter count does not match its structure")
        m.u_scale = np.array(d["scaling"]["u_scale"], dtype=float)
        m.y_mean, m.y_std = float(d["scaling"]["y_mean"]), float(d["scaling"]["y_std"])
        m.ts, m.inputs, m.output = float(d["ts"]), tuple(d["inputs"]), d["output"]
        m.info = dict(d.get("info", {}))
        sig = d.get("signals")  # absent in files written before units were stored
        if sig is not None:
            m.input_units = tuple(s.get("unit") for s in sig["inputs"])
            for unit in m.input_units:
                if unit is not None:
                    input_unit_scale(unit)
            m.output_unit = sig["output"].get("unit")
        return m

    def _signals(self) -> dict:
        """Name, unit and scale (model units per recorded unit: per % of dR for the inputs) of
        every input and of the output; unit None = undeclared."""
        n = len(self.inputs)
        units = tuple(self.input_units) if len(self.input_units) == n else (None,) * n
        return {
            "inputs": [
                {"name": name, "unit": unit, "scale": input_unit_scale(unit or "%")}
                for name, unit in zip(self.inputs, units)
            ],
            "output": {"name": self.output, "unit": self.output_unit, "scale": 1.0},
        }

    def save(self, path) -> Path:
        """Write the versioned JSON model file."""
        return save_models([self], path)

    def __repr__(self) -> str:
        state = f"fit sse={self.info['sse']:.4g}" if self.info else "not fitted"
        return (
            f"{type(self).__name__}(n_poles={self.n_poles}, n_zeros={self.n_zeros}, "
            f"n_breakpoints={self.n_breakpoints}, delay={self.delay}; {state})"
        )


def _tf(control, b, a, ts, delay):
    b = np.concatenate([np.zeros(delay), np.atleast_1d(b)])
    a = np.atleast_1d(a)
    # z^-1 polynomials -> z polynomials of equal length.
    n = max(len(b), len(a))
    return control.tf(np.pad(b, (0, n - len(b))), np.pad(a, (0, n - len(a))), ts)


class Linear(Model):
    """Output-error model: y = sum_i B_i(q)/F_i(q) u_i[k - delay] + c (like tfest/oe)."""

    kind = "linear"

    def _estimate(self, us, ys, opts):
        return estimate.fit_linear(us, ys, self.n_poles, self.n_zeros, self.delay, opts)


class Hammerstein(Model):
    """y = sum_i B_i/F_i f_i(u_i) + c with piecewise-linear f_i."""

    kind = "hammerstein"

    def _estimate(self, us, ys, opts):
        return estimate.fit_hammerstein(
            us,
            ys,
            self.n_poles,
            self.n_zeros,
            self.n_breakpoints,
            self.delay,
            opts,
            lin=self._start_fit(getattr(self, "_linear", None)),
        )


class Wiener(Model):
    """y = g(sum_i B_i/F_i u_i) + c with piecewise-linear g."""

    kind = "wiener"

    def _estimate(self, us, ys, opts):
        return estimate.fit_wiener(
            us,
            ys,
            self.n_poles,
            self.n_zeros,
            self.n_breakpoints,
            self.delay,
            opts,
            lin=self._start_fit(getattr(self, "_linear", None)),
        )


class WienerHammerstein(Model):
    """y = H2(g(sum_i H1_i(f_i(u_i)))) + c, the better of the paper's two builds.

    Order convention: one linear block carries ``n_poles`` poles and ``n_zeros`` zeros, the
    other is a first-order section (1 pole, 1 zero). "Wiener + linear": H1_i (n_poles,
    n_zeros) -> g -> H2 first order, started from the Wiener model of the same order.
    "linear + Hammerstein": H1 first order -> g -> H2 (n_poles, n_zeros), started from the
    Hammerstein model of the same order (its f becomes g); with several inputs the branches
    keep the Hammerstein's f_i -> H1_i (n_poles, n_zeros) and g, H2 follow the sum. Both
    starts are refined jointly, so the fit is at least that of the Wiener and of the
    Hammerstein model of the same order. ``info["build"]`` names the build kept.
    """

    kind = "wh"

    def fit(
        self,
        *,
        u,
        y,
        ts: float = 1.0,
        inputs=None,
        output: str = "y",
        wiener: Wiener | None = None,
        hammerstein: Hammerstein | None = None,
        linear: Linear | None = None,
        input_unit=None,
        output_unit: str | None = None,
    ) -> Model:
        """As :meth:`Model.fit`; ``wiener`` / ``hammerstein`` / ``linear``: models of the same
        orders already fitted on the same data (reused as the starts instead of being estimated
        again)."""
        self._parts = (wiener, hammerstein)
        try:
            return super().fit(
                u=u,
                y=y,
                ts=ts,
                inputs=inputs,
                output=output,
                linear=linear,
                input_unit=input_unit,
                output_unit=output_unit,
            )
        finally:
            self._parts = (None, None)

    def _part_fit(self, model):
        if model is None:
            return None
        same = (
            model.theta is not None
            and model.n_poles == self.n_poles
            and model.n_zeros == self.n_zeros
            and model.n_breakpoints == self.n_breakpoints
            and model.delay == self.delay
            and model.skip == self.skip
            and np.array_equal(model.u_scale, self.u_scale)
            and model.y_mean == self.y_mean
            and model.y_std == self.y_std
        )
        if not same:
            raise InputError(
                f"the {model.kind} model to start from must be fitted on the same data with the same orders"
            )
        if getattr(model, "_oe_fit", None) is not None:  # a process-noise model: its OE fit
            return model._oe_fit
        return estimate.Fit(model.spec, model.theta, model.info["sse"] / self.y_std**2)

    def _estimate(self, us, ys, opts):
        wiener, hammerstein = (self._part_fit(m) for m in getattr(self, "_parts", (None, None)))
        fits = estimate.wh_fits(
            us,
            ys,
            self.n_poles,
            self.n_zeros,
            self.n_breakpoints,
            self.delay,
            opts,
            wiener=wiener,
            hammerstein=hammerstein,
            linear=self._start_fit(getattr(self, "_linear", None)),
        )
        self.alternatives = fits[1:]
        return fits[0]


NOISE_KINDS = ("wiener", "wh")
KINDS = {"linear": Linear, "hammerstein": Hammerstein, "wiener": Wiener, "wh": WienerHammerstein}


def make_model(kind: str, **kwargs) -> Model:
    """Model of ``kind`` (linear, hammerstein, wiener, wh) with the given orders."""
    if kind not in KINDS:
        raise InputError(f"unknown structure {kind!r}; choose from {', '.join(KINDS)}")
    return KINDS[kind](**kwargs)


class ModelSet:
    """Several single-output models over the same inputs: one estimator with several outputs."""

    def __init__(self, models):
        self.models = list(models)
        if not self.models:
            raise ModelError("a model set needs at least one model")
        first = self.models[0]
        if any(m.inputs != first.inputs or m.ts != first.ts for m in self.models):
            raise ModelError("models of one set need the same inputs and sample time")
        if any(m._units()["input_units"] != first._units()["input_units"] for m in self.models):
            raise ModelError("models of one set need the same input units")

    @property
    def inputs(self):
        return self.models[0].inputs

    @property
    def outputs(self):
        return tuple(m.output for m in self.models)

    @property
    def ts(self):
        return self.models[0].ts

    def predict(self, *, u, expected: bool = False) -> np.ndarray:
        """(N, n_outputs) simulation from rest (``expected``: as in :meth:`Model.predict`)."""
        return np.column_stack([m.predict(u=u, expected=expected) for m in self.models])

    def to_structure(self) -> EstimatorStructure:
        units = [m._units() for m in self.models]
        peak = tuple(np.max([u["input_peak"] for u in units], axis=0))
        return EstimatorStructure(
            inputs=self.inputs,
            outputs=tuple(m.output_chain() for m in self.models),
            ts=self.ts,
            meta={"kinds": [m.kind for m in self.models]},
            input_units=units[0]["input_units"],
            output_units=tuple(u["output_units"][0] for u in units),
            input_peak=peak,
        )

    def save(self, path) -> Path:
        return save_models(self.models, path)


def save_models(models, path) -> Path:
    path = Path(path)
    doc = {"format": FORMAT, "version": FORMAT_VERSION, "models": [m.to_dict() for m in models]}
    write_text(path, json.dumps(doc, indent=1, allow_nan=False))
    return path


def load_model(path):
    """Load a model file: the single-output model, or a :class:`ModelSet` for several."""
    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError as exc:
        raise ModelError(f"model file {path} not found") from exc
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise ModelError(f"{path} is not a model file: {exc}") from exc
    if isinstance(doc, dict) and doc.get("format") == "porosense.ident.extended":
        from porosense.ident.extended import FORMAT_VERSION as EXT_VERSION
        from porosense.ident.extended import ExtendedModel

        if doc.get("version") != EXT_VERSION:
            raise ModelError(f"{path}: extended model version {doc.get('version')}, this build reads {EXT_VERSION}")
        return ExtendedModel.from_dict(doc)
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise ModelError(f"{path} is not a porosense model file")
    if doc.get("version") != FORMAT_VERSION:
        raise ModelError(f"{path}: model format version {doc.get('version')}, this build reads {FORMAT_VERSION}")
    try:
        models = [Model.from_dict(d) for d in doc["models"]]
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelError(f"{path}: malformed model file ({exc})") from exc
    return models[0] if len(models) == 1 else ModelSet(models)
