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
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import NamedTuple

import numpy as np

from porosense.data.model_file import MODEL_FORMAT, MODEL_FORMAT_VERSION
from porosense.dsp.blas import single_threaded
from porosense.dsp.heap import reuses_freed_memory
from porosense.errors import InputError, ModelError
from porosense.files import write_text
from porosense.ident import output_error
from porosense.ident.blocks import sos_rows
from porosense.ident.chain import Chain, ChainSpec
from porosense.ident.metrics import fit_percent, information_criteria, rms_percent
from porosense.ident.process_noise import with_process_noise
from porosense.ident.refine import Fit, Options, refine
from porosense.structure import Branch, EstimatorStructure, OutputChain, PiecewiseLinear, SOSCascade, input_unit_scale

FORMAT, FORMAT_VERSION = MODEL_FORMAT, MODEL_FORMAT_VERSION  # one definition, beside the file check
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


def check_ts(ts) -> float:
    """``ts`` as a float sample period in s, or an InputError saying why it cannot be one."""
    if isinstance(ts, bool) or not isinstance(ts, (int, float, np.integer, np.floating)):
        raise InputError(f"ts must be a sample period in seconds (a number), not {ts!r}")
    value = float(ts)
    if not (np.isfinite(value) and value > 0):
        raise InputError(f"ts must be a positive, finite sample period in seconds, not {ts!r}")
    return value


@dataclass(frozen=True)
class Scaling:
    """The normalisation inside a model: inputs divided by ``u_scale`` (their largest magnitude),
    the output standardised by ``y_mean`` and ``y_std`` (data units)."""

    u_scale: tuple
    y_mean: float
    y_std: float

    @classmethod
    def of(cls, us, ys) -> Scaling:
        """The scaling of recordings ``us`` (list of (N, n_in)) and ``ys`` (list of (N,))."""
        scale = np.max(np.vstack([np.max(np.abs(x), axis=0) for x in us]), axis=0)
        all_y = np.concatenate(ys)
        return cls(
            tuple(float(v) for v in np.where(scale > 0, scale, 1.0)),
            float(np.mean(all_y)),
            float(np.std(all_y)) or 1.0,
        )

    def apply(self, us, ys):
        """(normalised inputs, normalised outputs)."""
        scale = np.asarray(self.u_scale, dtype=float)
        return [x / scale for x in us], [(v - self.y_mean) / self.y_std for v in ys]


@dataclass(frozen=True)
class Starts:
    """Fits of the same data and orders that a nonlinear model starts from instead of estimating
    them again (normalised units; None: estimated)."""

    linear: Fit | None = None
    wiener: Fit | None = None
    hammerstein: Fit | None = None


class Fitted(NamedTuple):
    """What a fitted model holds beyond its orders: structure, parameters (normalised units)
    and the input scales (data units per normalised unit)."""

    spec: ChainSpec
    theta: np.ndarray
    u_scale: np.ndarray


class Model:
    """Common base of the four structures: orders, fitting, prediction, conversion and storage.

    One output over 1 to 3 inputs, discrete time at the data's sample period; fitted on
    simulation error jointly over several recordings (each simulated from rest).

    Parameters
    ----------
    n_poles, n_zeros : int
        Order of the main linear block, >= 0 (the Wiener-Hammerstein's other block is first order).
    n_breakpoints : int
        Breakpoints of each piecewise-linear map, 2..64 (the firmware takes 16).
    delay : int
        Pure input delay, samples, >= 0.
    starts : int
        Starting points refined for a nonlinear structure (the best is kept).
    max_nfev : int
        Residual evaluations per refinement at most.
    skip : int
        Leading samples of every recording not scored (a transient the model cannot know).
    smoothness : float
        Weight of the second differences of the maps' values, >= 0, dimensionless (0: none).
    monotone : bool
        Keep every piecewise-linear map monotone.
    process_noise : bool
        Also estimate a Gaussian process noise at g's input (Wiener and WH models only).
    bend_prior : bool
        Refine the piecewise-linear maps under the prior on their slope changes
        (:mod:`porosense.ident.pwl_prior`: its weight is measured on the data, none to choose).

    Raises
    ------
    InputError
        Negative orders or delay, breakpoints outside 2..64, negative smoothness, or process noise
        for a structure without g.
    """

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
        bend_prior: bool = True,
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
        # Regularisation of the piecewise-linear values (refine._penalty_rows).
        self.smoothness, self.monotone = float(smoothness), bool(monotone)
        # The prior on the maps' slope changes (pwl_prior), weighted by the data's own error level.
        self.bend_prior = bool(bend_prior)
        # Estimate a Gaussian noise at g's input with g (process_noise.with_process_noise).
        self.process_noise = bool(process_noise)
        if self.process_noise and self.kind not in NOISE_KINDS:
            raise InputError(
                f"process noise enters before a map g: only {' and '.join(NOISE_KINDS)} models take it, not {self.kind}"
            )
        self.spec: ChainSpec | None = None
        self.theta: np.ndarray | None = None
        self.u_scale: np.ndarray | None = None
        self.y_mean = 0.0
        self.y_std = 1.0
        self.ts = 1.0
        self.inputs: tuple[str, ...] = ()
        self.output = "y"
        self.info: dict = {}
        self.alternatives: list[Fit] = []  # the fit's other members (alternative_models)
        self.output_error_fit: Fit | None = None  # with process noise: the fit it was refined from
        self.converged = True  # the last refine() met its tolerance
        self.input_units: tuple = ()  # per input "%" or "dR/100"; None entries: undeclared
        self.output_unit: str | None = None

    # -- estimation -----------------------------------------------------------------

    def _estimate(self, us, ys, opts: Options, starts: Starts) -> tuple[Fit, list[Fit]]:  # pragma: no cover
        """(the fit, its other members) on normalised data; abstract."""
        raise NotImplementedError

    def fit(
        self,
        *,
        u,
        y,
        ts: float,
        inputs=None,
        output: str = "y",
        input_unit=None,
        output_unit: str | None = None,
        linear: Model | None = None,
        scaling: Scaling | None = None,
    ) -> Model:
        """Estimate on the recordings ``u`` (list of (N, n_in)), ``y`` (list of (N,)).

        Parameters
        ----------
        u, y : array or list of arrays
            Inputs (N, n_inputs) and output (N,) of one recording or lists of them, in the
            data's units; each recording is simulated from rest.
        ts : float
            Sample period in s (required: a model carries its rate to predict, quantize and
            flash).
        inputs, output : names of the input columns and of the output.
        input_unit : str or list, optional
            What ``u`` holds, "%" (dR in %) or "dR/100" (dR as a fraction), one for all inputs
            or one per input; stored in the model file and used by the quantizer.
        output_unit : str, optional
            Free text (for example "%" of strain or "deg").
        linear : Model, optional
            The linear model of the same orders already fitted on the same data; a nonlinear
            structure starts from it instead of estimating it again.
        scaling : Scaling, optional
            The normalisation to use instead of the data's own (a model fitted on part of a
            record set keeps the scaling of the whole, so that its parameters start the fit on
            the whole, :meth:`refine`).

        Returns
        -------
        Model
            ``self``, fitted.
        """
        return self._fit(
            u=u,
            y=y,
            ts=ts,
            inputs=inputs,
            output=output,
            input_unit=input_unit,
            output_unit=output_unit,
            start_models={"linear": linear},
            scaling=scaling,
        )

    def _start_fit(self, model, kind: str) -> Fit | None:
        """The Fit (normalised units) of ``model``, a fitted ``kind`` model of the same data and
        orders as this one, or None; a process-noise model gives its output-error fit."""
        if model is None:
            return None
        assert self.u_scale is not None  # _fit sets this model's scaling before its starts
        same = (
            model.theta is not None
            and model.kind == kind
            and model.n_poles == self.n_poles
            and model.n_zeros == self.n_zeros
            and (kind == "linear" or model.n_breakpoints == self.n_breakpoints)
            and model.delay == self.delay
            and model.skip == self.skip
            and np.array_equal(model.u_scale, self.u_scale)
            and model.y_mean == self.y_mean
            and model.y_std == self.y_std
        )
        if not same:
            raise InputError(f"the {kind} model to start from must be fitted on the same data with the same orders")
        if model.output_error_fit is not None:
            return model.output_error_fit
        return Fit(model.spec, model.theta, model.info["sse"] / self.y_std**2)

    @reuses_freed_memory
    @single_threaded
    def _fit(
        self, *, u, y, ts, inputs, output, input_unit=None, output_unit=None, start_models=None, scaling=None
    ) -> Model:
        us, ys = as_recordings(u, y)
        n_in = us[0].shape[1]
        if not 1 <= n_in <= MAX_INPUTS or any(x.shape[1] != n_in for x in us):
            raise InputError(f"every recording needs the same 1..{MAX_INPUTS} input columns")
        if min(len(v) for v in ys) < self.skip + 10:
            raise InputError(f"every recording needs at least skip + 10 = {self.skip + 10} samples")
        self.ts = check_ts(ts)
        self.inputs = tuple(inputs) if inputs is not None else tuple(f"u{i}" for i in range(n_in))
        self.output = output
        units = [input_unit] * n_in if input_unit is None or isinstance(input_unit, str) else list(input_unit)
        if len(units) != n_in:
            raise InputError(f"input_unit: one unit or one per input ({n_in})")
        for unit in units:
            if unit is not None:
                input_unit_scale(unit)  # raises on an unknown unit
        self.input_units, self.output_unit = tuple(units), output_unit
        scaling = scaling or Scaling.of(us, ys)
        if len(scaling.u_scale) != n_in:
            raise InputError(f"scaling: {len(scaling.u_scale)} input scales for {n_in} inputs")
        self.u_scale = np.array(scaling.u_scale, dtype=float)
        self.y_mean, self.y_std = float(scaling.y_mean), float(scaling.y_std)
        nus, nys = scaling.apply(us, ys)
        starts = Starts(**{k: self._start_fit(m, k) for k, m in (start_models or {}).items()})
        opts = self._options()
        result, alternatives = self._estimate(nus, nys, opts, starts)
        self.output_error_fit = None
        if self.process_noise:
            # The output-error fit stays a member (the search scores it too) and the start of
            # a WH model built from this one.
            self.output_error_fit = result
            noisy = with_process_noise(result, nus, nys, opts, alternatives=alternatives)
            alternatives = [result] + list(alternatives)
            result = noisy
        self.alternatives = list(alternatives)
        self._set_result(result, sum(len(v) - self.skip for v in ys))
        return self

    def refine(self, *, u, y, skip: int | None = None, max_nfev: int | None = None) -> Model:
        """A copy of this fitted model with its parameters refined on the recordings ``u``, ``y``
        (data units, each simulated from rest, the first ``skip`` samples unscored), keeping its
        scaling, structure and process-noise level; its other members are dropped.

        The order search fits candidates on part of long records and refines the finalists on
        all of them this way (the fit is already close, so few evaluations are needed).

        Parameters
        ----------
        u, y : array or list of arrays
            Inputs (N, n_inputs) and output (N,) per recording, in the data's units.
        skip : int, optional
            Leading samples of every recording not scored (default the model's ``skip``); the
            copy keeps it.
        max_nfev : int, optional
            Residual evaluations at most (default the model's ``max_nfev``).

        Returns
        -------
        Model
            The refined copy; its ``info["nfev"]`` adds the evaluations spent here and its
            ``converged`` says whether the optimiser met its tolerance within them.
        """
        spec, theta, u_scale = self._require_fitted()
        us, ys = as_recordings(u, y)
        if any(x.shape[1] != len(self.inputs) for x in us):
            raise InputError(f"expected {len(self.inputs)} input columns")
        nus, nys = Scaling(tuple(u_scale), self.y_mean, self.y_std).apply(us, ys)
        frozen = (spec.slices()["g.s"].start,) if spec.g_noise else ()
        skip = self.skip if skip is None else int(skip)
        if min(len(v) for v in ys) < skip + 10:
            raise InputError(f"every recording needs at least skip + 10 = {skip + 10} samples")
        opts = replace(self._options(), skip=skip, max_nfev=int(max_nfev or self.max_nfev), frozen=frozen)
        fit = refine(spec, theta, nus, nys, opts)
        out = copy.copy(self)
        out.skip, out.converged = skip, fit.converged
        out.alternatives, out.output_error_fit = [], None
        notes = {k: v for k, v in self.info.items() if k not in ("sse", "n_samples", "aic", "bic", "nfev")}
        out._set_result(fit, sum(len(v) - skip for v in ys))
        out.info.update(notes)
        out.info["nfev"] = int(self.info.get("nfev", 0)) + fit.nfev
        return out

    def _options(self) -> Options:
        return Options(
            max_nfev=self.max_nfev,
            skip=self.skip,
            starts=self.starts,
            smoothness=self.smoothness,
            monotone=self.monotone,
            bend_prior=self.bend_prior,
        )

    def _set_result(self, result: Fit, n: int) -> None:
        """Take the parameters of ``result`` (normalised units) and its criteria over n samples."""
        self.spec, self.theta = result.spec, np.asarray(result.theta, dtype=float)
        sse = result.sse * self.y_std**2
        aic, bic = information_criteria(sse, n, self.n_params)
        self.info = {"sse": sse, "n_samples": n, "aic": aic, "bic": bic, "nfev": result.nfev}
        if result.build:
            self.info["build"] = result.build
        self.info.update(result.notes)

    # -- use --------------------------------------------------------------------------

    def _require_fitted(self) -> Fitted:
        """The fitted parts; a ModelError before fitting."""
        if self.spec is None or self.theta is None or self.u_scale is None:
            raise ModelError(f"{type(self).__name__} is not fitted yet")
        return Fitted(self.spec, self.theta, self.u_scale)

    def predict(self, *, u, expected: bool = False) -> np.ndarray:
        """Simulate from rest.

        A model with process noise (``process_noise_std`` > 0) predicts the noise-free system by
        default: g itself, the map the board runs after ``quantize``, and what a recording without
        that noise shows. ``expected=True`` gives instead the output averaged over the estimated
        noise, E[H2 g(H1 u + v)], which is what a recording carrying the same noise matches best
        (the order search scores such models this way). Other models: the same.

        Parameters
        ----------
        u : array_like, shape (N, n_inputs) or (N,)
            Inputs, in the units of the data the model was fitted on.
        expected : bool
            Average over the process noise (see above).

        Returns
        -------
        ndarray, shape (N,)
            Output, output units.

        Raises
        ------
        ModelError
            A model not fitted yet.
        InputError
            Another number of input columns.
        """
        spec, theta, u_scale = self._require_fitted()
        x = np.asarray(u, dtype=float)
        x = x[:, None] if x.ndim == 1 else x
        if x.shape[1] != len(self.inputs):
            raise InputError(f"expected {len(self.inputs)} input columns, got {x.shape[1]}")
        return Chain(spec, theta).simulate(x / u_scale, expected=expected) * self.y_std + self.y_mean

    @property
    def process_noise_std(self) -> float:
        """Standard deviation of the estimated Gaussian noise at g's input, in the units of g's
        input in :meth:`to_structure` (0 for a model without process noise)."""
        spec, theta, _ = self._require_fitted()
        return Chain(spec, theta).g_sigma if spec.g_noise else 0.0

    def score(self, *, u, y, skip: int = 0, expected: bool = False) -> dict:
        """Per recording fit and RMS (docs/design.md metrics) of the output simulated from rest.

        Parameters
        ----------
        u, y : array or list of arrays
            Inputs (N, n_inputs) and output (N,) per recording, data units.
        skip : int
            Leading samples of each recording simulated but not scored.
        expected : bool
            As in :meth:`predict`.

        Returns
        -------
        dict
            ``fit``: NRMSE fit per recording, %; ``rms``: RMS error per recording, % of max |y|.
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
        """The other members of this fit, as models.

        For WH the other build's refinement and the starting models (WH models with identity
        blocks, equal to the Wiener / Hammerstein model each came from); with process noise also
        the output-error fit it was refined from. The order search scores them too and keeps the
        best by its selection rule.

        Returns
        -------
        list of Model
            Fitted models of this model's class.
        """
        self._require_fitted()
        out = []
        for fit in self.alternatives:
            m = copy.copy(self)
            m.alternatives, m.output_error_fit, m.process_noise = [], None, fit.spec.g_noise
            m._set_result(fit, self.info["n_samples"])
            out.append(m)
        return out

    # -- conversion -------------------------------------------------------------------

    def to_structure(self) -> EstimatorStructure:
        """The float estimator structure that quant and the firmware run.

        Returns
        -------
        EstimatorStructure
            One output, in the raw units of the data (scalings folded into the blocks), with the
            input units and identification peaks.

        Raises
        ------
        ModelError
            A model not fitted yet.
        """
        spec = self._require_fitted().spec
        return EstimatorStructure(
            inputs=self.inputs,
            outputs=(self.output_chain(),),
            ts=self.ts,
            meta={
                "kind": self.kind,
                "n_poles": self.n_poles,
                "n_zeros": self.n_zeros,
                **({"process_noise_std": self.process_noise_std} if spec.g_noise else {}),
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
            "input_peak": tuple(float(v) for v in self._require_fitted().u_scale),
        }

    def output_chain(self) -> OutputChain:
        """This model as one output chain with the scalings folded into the blocks.

        Returns
        -------
        OutputChain
            In the raw units of the data.
        """
        spec, theta, u_scale = self._require_fitted()
        c = Chain(spec, theta)
        out_gain_on_h1 = c.g is None and c.h2 is None
        branches = []
        for i in range(spec.n_inputs):
            b, den, _ = c.h1[i]
            b = np.array(b, dtype=float)
            f = None
            fi = c.f[i]
            if fi is not None:
                f = PiecewiseLinear(fi[0] * u_scale[i], np.array(fi[1], dtype=float))
            else:
                b = b / u_scale[i]
            if out_gain_on_h1:
                b = b * self.y_std
            branches.append(Branch(input=i, h1=SOSCascade(sos_rows(b, den)), f=f, delay=spec.delay))
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
        """python-control TransferFunction of each linear block, in the structure's units.

        Returns
        -------
        dict of str to control.TransferFunction
            ``h1[<input name>]`` per input and ``h2`` when present, sample time ``ts`` s (delays
            included).
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
        """A C header with the float coefficients of :meth:`to_structure`.

        Parameters
        ----------
        name : str or None
            C name (None: ``porosense_<output>``).

        Returns
        -------
        str
            The header text.
        """
        from porosense.ident.export import c_header

        return c_header(self.to_structure(), name or f"porosense_{self.output}")

    # -- storage ----------------------------------------------------------------------

    def to_dict(self) -> dict:
        """The model file's entry for this model, in plain JSON types.

        Returns
        -------
        dict
            Kind, orders, options, parameters, scaling, ``ts`` (s), signals with their units and
            the fit's information; floats survive json.dumps/json.loads exactly.
        """
        spec, theta, u_scale = self._require_fitted()
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
                **({} if self.bend_prior else {"bend_prior": False}),
            },
            "spec": asdict(spec),
            "theta": [float(v) for v in theta],
            "scaling": {"u_scale": [float(v) for v in u_scale], "y_mean": self.y_mean, "y_std": self.y_std},
            "ts": self.ts,
            "inputs": list(self.inputs),
            "output": self.output,
            "signals": self._signals(),
            "info": {k: (float(v) if isinstance(v, (float, np.floating)) else v) for k, v in self.info.items()},
        }

    @classmethod
    def from_dict(cls, d: dict) -> Model:
        """A fitted model from :meth:`to_dict` output.

        Parameters
        ----------
        d : dict
            One model of a model file.

        Returns
        -------
        Model
            An instance of its kind's class.

        Raises
        ------
        ModelError
            An unknown kind or a parameter count that does not match the structure.
        """
        kind = d.get("kind")
        klass = KINDS.get(kind) if isinstance(kind, str) else None
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
        """Write the versioned JSON model file (whole or not at all).

        Parameters
        ----------
        path : str or Path
            The model file.

        Returns
        -------
        Path
            The file written.
        """
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
    """Output-error model: y = sum_i B_i(q)/F_i(q) u_i[k - delay] + c (like tfest/oe).

    Constructed with the parameters of :class:`Model`.
    """

    kind = "linear"

    def _estimate(self, us, ys, opts, starts):
        return output_error.fit_linear(us, ys, self.n_poles, self.n_zeros, self.delay, opts), []


class Hammerstein(Model):
    """Hammerstein model: y = sum_i B_i/F_i f_i(u_i) + c with piecewise-linear f_i.

    Constructed with the parameters of :class:`Model`.
    """

    kind = "hammerstein"

    def _estimate(self, us, ys, opts, starts):
        fit = output_error.fit_hammerstein(
            us, ys, self.n_poles, self.n_zeros, self.n_breakpoints, self.delay, opts, lin=starts.linear
        )
        return fit, []


class Wiener(Model):
    """Wiener model: y = g(sum_i B_i/F_i u_i) + c with piecewise-linear g.

    Constructed with the parameters of :class:`Model`.
    """

    kind = "wiener"

    def _estimate(self, us, ys, opts, starts):
        fit = output_error.fit_wiener(
            us, ys, self.n_poles, self.n_zeros, self.n_breakpoints, self.delay, opts, lin=starts.linear
        )
        return fit, []


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
        ts: float,
        inputs=None,
        output: str = "y",
        wiener: Wiener | None = None,
        hammerstein: Hammerstein | None = None,
        linear: Model | None = None,
        input_unit=None,
        output_unit: str | None = None,
        scaling: Scaling | None = None,
    ) -> Model:
        """Estimate on the recordings, as :meth:`Model.fit`, optionally from models already fitted.

        Parameters
        ----------
        u, y : array or list of arrays
            Inputs (N, n_inputs) and output (N,) of one recording or lists of them, data units; each
            recording is simulated from rest.
        ts : float
            Sample period, s.
        inputs : sequence of str or None
            Input names (None: ``u0``, ``u1``, ...).
        output : str
            Output name.
        wiener, hammerstein, linear : Model or None
            Models of the same orders already fitted on the same data, reused as the starts instead
            of being estimated again.
        input_unit : str or sequence of str or None
            ``"%"`` (dR in %) or ``"dR/100"``, one for all inputs or one per input.
        output_unit : str or None
            Free text (e.g. ``"%"`` of strain, ``"deg"``).
        scaling : Scaling or None
            The normalisation to use instead of the data's own.

        Returns
        -------
        Model
            ``self``, fitted.

        Raises
        ------
        InputError
            Recordings of different widths, too short, not finite, or a bad unit or period.
        """
        return self._fit(
            u=u,
            y=y,
            ts=ts,
            inputs=inputs,
            output=output,
            input_unit=input_unit,
            output_unit=output_unit,
            start_models={"linear": linear, "wiener": wiener, "hammerstein": hammerstein},
            scaling=scaling,
        )

    def _estimate(self, us, ys, opts, starts):
        fits = output_error.wh_fits(
            us,
            ys,
            self.n_poles,
            self.n_zeros,
            self.n_breakpoints,
            self.delay,
            opts,
            wiener=starts.wiener,
            hammerstein=starts.hammerstein,
            linear=starts.linear,
        )
        return fits[0], fits[1:]


NOISE_KINDS = ("wiener", "wh")
KINDS = {"linear": Linear, "hammerstein": Hammerstein, "wiener": Wiener, "wh": WienerHammerstein}


def make_model(kind: str, **kwargs) -> Model:
    """A model of ``kind`` with the given orders, not fitted.

    Parameters
    ----------
    kind : str
        ``"linear"``, ``"hammerstein"``, ``"wiener"`` or ``"wh"``.
    **kwargs
        The constructor's parameters (:class:`Model`: ``n_poles``, ``n_zeros``, ``n_breakpoints``,
        ...).

    Returns
    -------
    Model
        An instance of the structure's class.

    Raises
    ------
    InputError
        An unknown structure or a bad order.
    """
    if kind not in KINDS:
        raise InputError(f"unknown structure {kind!r}; choose from {', '.join(KINDS)}")
    return KINDS[kind](**kwargs)


class ModelSet:
    """Several single-output models over the same inputs: one estimator with several outputs.

    Parameters
    ----------
    models : sequence of Model
        Fitted models, one per output, with the same inputs, input units and sample period.

    Raises
    ------
    ModelError
        No model, or models whose inputs, units or sample periods differ.
    """

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
        """Simulate every output from rest.

        Parameters
        ----------
        u : array_like, shape (N, n_inputs)
            Inputs, data units.
        expected : bool
            As in :meth:`Model.predict`.

        Returns
        -------
        ndarray, shape (N, n_outputs)
            Outputs, each in its unit.
        """
        return np.column_stack([m.predict(u=u, expected=expected) for m in self.models])

    def to_structure(self) -> EstimatorStructure:
        """One estimator with every output.

        Returns
        -------
        EstimatorStructure
            The outputs' chains over the shared inputs, sample period ``ts`` s.
        """
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
        """Write the versioned JSON model file (whole or not at all).

        Parameters
        ----------
        path : str or Path
            The model file.

        Returns
        -------
        Path
            The file written.
        """
        return save_models(self.models, path)


def save_models(models, path) -> Path:
    """Write ``models`` (fitted, one per output) as one versioned JSON model file.

    Written to a temporary file beside ``path`` and renamed over it, so an interrupted save
    leaves the old file (or none), never a partial one.

    Parameters
    ----------
    models : sequence of Model
        Fitted models, one per output.
    path : str or Path
        The model file.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    doc = {"format": FORMAT, "version": FORMAT_VERSION, "models": [m.to_dict() for m in models]}
    write_text(path, json.dumps(doc, indent=1, allow_nan=False))
    return path
