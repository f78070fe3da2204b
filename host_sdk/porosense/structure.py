"""The estimator structure of docs/design.md in floating point: the contract between ident and quant.

For each output j over inputs i::

    y_j = offset_j + H2_j( g_j( sum_i H1_ij( f_ij( u_i[k - delay_ij] - u_offset_ij ) ) ) )

``f`` and ``g`` are piecewise-linear (linear beyond the outer breakpoints); ``H1`` and ``H2``
are cascades of second-order sections in scipy's ``sos`` layout ``[b0 b1 b2 1 a1 a2]``.
Any block may be absent (identity). Every identified model converts to an
``EstimatorStructure``; quant turns it into fixed point, and its ``simulate`` is the float
reference the fixed-point fit is compared with.

Limits of the firmware (checked by :meth:`EstimatorStructure.check_limits`): at most 3 inputs
and 3 outputs, 16 breakpoints per nonlinearity, 5 sections (10 poles) per linear block, input
delays of at most 15 samples.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from porosense.dsp import fold_delay, split_delay
from porosense.errors import ModelError

MAX_INPUTS = 3
MAX_OUTPUTS = 3
MAX_BREAKPOINTS = 16
MAX_SECTIONS = 5
MAX_DELAY = 15

__all__ = [
    "MAX_INPUTS",
    "MAX_OUTPUTS",
    "MAX_BREAKPOINTS",
    "MAX_SECTIONS",
    "MAX_DELAY",
    "INPUT_UNITS",
    "DEVICE_LSB_PERCENT",
    "PiecewiseLinear",
    "SOSCascade",
    "Branch",
    "OutputChain",
    "EstimatorStructure",
    "input_unit_scale",
]


@dataclass(frozen=True)
class PiecewiseLinear:
    """Static piecewise-linear map through breakpoints (x[k], y[k]); linear beyond the ends.

    Attributes
    ----------
    x : ndarray, shape (n,)
        Breakpoints, strictly increasing, n >= 2, in the unit of the block's input (an f block:
        structure input units, % dR unless declared otherwise; a g block: the branch sum's unit).
    y : ndarray, shape (n,)
        Values at the breakpoints, in the block's output unit.

    Raises
    ------
    ModelError
        Fewer than 2 breakpoints, shapes that differ, NaN or inf, or breakpoints not increasing.
    """

    x: np.ndarray
    y: np.ndarray

    def __post_init__(self):
        x = np.asarray(self.x, dtype=float)
        y = np.asarray(self.y, dtype=float)
        if x.ndim != 1 or x.shape != y.shape or len(x) < 2:
            raise ModelError("a piecewise-linear map needs at least 2 breakpoints with matching x and y")
        for name, v in (("breakpoints", x), ("values", y)):
            if np.isnan(v).any():
                raise ModelError(f"piecewise-linear {name} hold NaN (not a number)")
            if np.isinf(v).any():
                raise ModelError(f"piecewise-linear {name} hold an infinite value (inf)")
        if np.any(np.diff(x) <= 0):
            raise ModelError("piecewise-linear breakpoints must be strictly increasing")
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "y", y)

    def __call__(self, u) -> np.ndarray:
        """Evaluate the map at ``u`` (array), extrapolating the outer segments."""
        u = np.asarray(u, dtype=float)
        x, y = self.x, self.y
        k = np.clip(np.searchsorted(x, u, side="right") - 1, 0, len(x) - 2)
        slope = (y[k + 1] - y[k]) / (x[k + 1] - x[k])
        return y[k] + slope * (u - x[k])

    @property
    def slopes(self) -> np.ndarray:
        """Slope of each of the len(x) - 1 segments."""
        return np.diff(self.y) / np.diff(self.x)


@dataclass(frozen=True)
class SOSCascade:
    """Linear block as a cascade of second-order sections (discrete time, z^-1).

    Attributes
    ----------
    sos : ndarray, shape (n_sections, 6)
        Rows ``[b0 b1 b2 1 a1 a2]`` in scipy's layout (a0 normalised to 1); dimensionless, the
        gain is the block's output unit per input unit.

    Raises
    ------
    ModelError
        A shape other than (n, 6) with n >= 1, or a row whose a0 is not 1.
    """

    sos: np.ndarray

    def __post_init__(self):
        sos = np.atleast_2d(np.asarray(self.sos, dtype=float))
        if sos.ndim != 2 or sos.shape[1] != 6 or sos.shape[0] < 1:
            raise ModelError("sos must have shape (n_sections, 6)")
        if not np.allclose(sos[:, 3], 1.0):
            raise ModelError("sos rows must be normalised so that a0 = 1")
        object.__setattr__(self, "sos", sos)

    @classmethod
    def from_tf(cls, b, a) -> SOSCascade:
        """A cascade from a transfer function in z^-1.

        Leading zeros of ``b`` are pure delays and are kept (scipy's tf2sos would drop them).

        Parameters
        ----------
        b, a : array_like
            Numerator and denominator coefficients of z^-1 in ascending powers (scipy's lfilter
            form); ``a[0]`` not zero.

        Returns
        -------
        SOSCascade
            The same response as second-order sections.

        Raises
        ------
        ModelError
            A denominator that starts with zero.
        """
        b = np.trim_zeros(np.atleast_1d(np.asarray(b, dtype=float)), "b")
        a = np.trim_zeros(np.atleast_1d(np.asarray(a, dtype=float)), "b")
        if len(b) == 0:
            return cls(np.array([[0.0, 0, 0, 1, 0, 0]]))
        if len(a) == 0 or a[0] == 0:
            raise ModelError("the denominator must start with a non-zero coefficient")
        b, a = b / a[0], a / a[0]
        delay, b = split_delay(b)
        zeros = np.roots(b) if len(b) > 1 else np.array([])
        poles = np.roots(a) if len(a) > 1 else np.array([])
        n_pairs = max(1, (max(len(zeros), len(poles)) + 1) // 2)
        # Pad with roots at the origin: in z^-1 form they are factors of 1 (no effect).
        zeros = np.concatenate([zeros, np.zeros(2 * n_pairs - len(zeros))])
        poles = np.concatenate([poles, np.zeros(2 * n_pairs - len(poles))])
        sos = signal.zpk2sos(zeros, poles, b[0], pairing="nearest")
        sos = sos[np.any(sos != [1, 0, 0, 1, 0, 0], axis=1)] if len(sos) > 1 else sos
        return cls(fold_delay(sos, delay))

    def to_tf(self) -> tuple[np.ndarray, np.ndarray]:
        """The cascade as one transfer function.

        Returns
        -------
        b, a : ndarray
            Coefficients of z^-1 in ascending powers.
        """
        return signal.sos2tf(self.sos)

    @property
    def n_sections(self) -> int:
        return self.sos.shape[0]

    @property
    def dc_gain(self) -> float:
        """Gain at z = 1."""
        return float(np.prod(self.sos[:, :3].sum(axis=1) / self.sos[:, 3:].sum(axis=1)))

    def poles(self) -> np.ndarray:
        """The poles of every section.

        Returns
        -------
        ndarray of complex
            Two per section, in the z plane.
        """
        return np.concatenate([np.roots(row[3:]) for row in self.sos])

    def is_stable(self) -> bool:
        """Whether every pole lies inside the unit circle.

        Returns
        -------
        bool
            True when stable.
        """
        return bool(np.all(np.abs(self.poles()) < 1.0))

    def filter(self, u) -> np.ndarray:
        """Filter a signal from rest (zero initial state).

        Parameters
        ----------
        u : array_like
            Input, one value per sample.

        Returns
        -------
        ndarray
            Output, same length.
        """
        return signal.sosfilt(self.sos, np.asarray(u, dtype=float))


@dataclass(frozen=True)
class Branch:
    """Input path i -> output j: delay, offset removal, f, then H1.

    Attributes
    ----------
    input : int
        Index of the input this branch reads (0-based).
    h1 : SOSCascade
        The branch's linear block.
    f : PiecewiseLinear or None
        Input nonlinearity, None for identity.
    delay : int
        Pure input delay, samples (0..15 on the firmware).
    u_offset : float
        Subtracted from the input before f, structure input units (% dR unless declared).
    """

    input: int
    h1: SOSCascade
    f: PiecewiseLinear | None = None
    delay: int = 0
    u_offset: float = 0.0


@dataclass(frozen=True)
class OutputChain:
    """One output: the sum of its branches, then g, then H2, then an offset.

    Attributes
    ----------
    name : str
        Output name (e.g. ``"p1"``).
    branches : tuple of Branch
        One per input path summed into this output.
    g : PiecewiseLinear or None
        Output nonlinearity after the sum, None for identity.
    h2 : SOSCascade or None
        Output linear block, None for identity.
    offset : float
        Added last, in the output's unit (kPa for pressure outputs).
    """

    name: str
    branches: tuple[Branch, ...]
    g: PiecewiseLinear | None = None
    h2: SOSCascade | None = None
    offset: float = 0.0

    @property
    def kind(self) -> str:
        """linear, hammerstein, wiener or wh, from the blocks present."""
        has_f = any(b.f is not None for b in self.branches)
        if self.g is None and self.h2 is None:
            return "hammerstein" if has_f else "linear"
        if self.h2 is None and not has_f:
            return "wiener"
        return "wh"


# Units a model's dR inputs may be given in: structure input units per % of dR.
INPUT_UNITS = {"%": 1.0, "dR/100": 0.01}
DEVICE_LSB_PERCENT = 0.01  # the device sends dR in 0.01 % steps


def input_unit_scale(unit: str) -> float:
    """Structure input units per % of dR for a unit name.

    Parameters
    ----------
    unit : str
        ``"%"`` (dR in %) or ``"dR/100"`` (dR as a fraction).

    Returns
    -------
    float
        1.0 for ``"%"``, 0.01 for ``"dR/100"``.

    Raises
    ------
    ModelError
        Any other unit name.
    """
    if unit not in INPUT_UNITS:
        raise ModelError(f"unknown input unit {unit!r}; choose from {', '.join(INPUT_UNITS)}")
    return INPUT_UNITS[unit]


@dataclass(frozen=True)
class EstimatorStructure:
    """A whole estimator: one multi-input single-output chain per output.

    Attributes
    ----------
    inputs : tuple of str
        Input names (1 to 3 on the firmware), e.g. ``("dR1", "dR2")``.
    outputs : tuple of OutputChain
        One chain per output (1 to 3 on the firmware).
    ts : float
        Sample period, s.
    meta : dict
        Free provenance (model kind, orders, fit), stored with the model.
    input_units : tuple
        Per input, ``"%"`` (dR in %) or ``"dR/100"`` (dR as a fraction), or None when the model
        did not declare it (then read as %).
    output_units : tuple
        Free text per output (e.g. ``"kPa"``).
    input_peak : tuple
        Per input, the largest |input| seen in identification, structure input units (empty when
        unknown): the quantizer uses it to catch a fraction model declared as %.
    """

    inputs: tuple[str, ...]
    outputs: tuple[OutputChain, ...]
    ts: float
    meta: dict = field(default_factory=dict)
    input_units: tuple = ()
    output_units: tuple = ()
    input_peak: tuple = ()

    def input_unit(self, i: int) -> str | None:
        """The declared unit of one input.

        Parameters
        ----------
        i : int
            Input index, 0-based.

        Returns
        -------
        str or None
            ``"%"``, ``"dR/100"``, or None when undeclared (read as %).
        """
        return self.input_units[i] if i < len(self.input_units) else None

    def input_lsb(self) -> float:
        """The device's input step (0.01 % of dR) in structure input units.

        Returns
        -------
        float
            0.01 for inputs in %, 1e-4 for inputs in dR/100.

        Raises
        ------
        ModelError
            Inputs with different units (the blob has one input scaling).
        """
        scales = {input_unit_scale(self.input_unit(i) or "%") for i in range(len(self.inputs))}
        if len(scales) != 1:
            raise ModelError("the model's inputs have different units; the device takes one scaling for all")
        return DEVICE_LSB_PERCENT * scales.pop()

    def simulate(self, u) -> np.ndarray:
        """Simulate the estimator from rest (the float reference of the fixed-point one).

        Parameters
        ----------
        u : array_like, shape (N, n_inputs) or (N,)
            Inputs, structure input units (% dR unless declared dR/100).

        Returns
        -------
        ndarray, shape (N, n_outputs)
            Outputs, in each output's unit.

        Raises
        ------
        ModelError
            A number of input columns other than the structure's.
        """
        u = np.asarray(u, dtype=float)
        if u.ndim == 1:
            u = u[:, None]
        if u.shape[1] != len(self.inputs):
            raise ModelError(f"expected {len(self.inputs)} input columns, got {u.shape[1]}")
        n = u.shape[0]
        y = np.zeros((n, len(self.outputs)))
        for j, out in enumerate(self.outputs):
            s = np.zeros(n)
            for br in out.branches:
                x = u[:, br.input] - br.u_offset
                if br.delay:
                    x = np.concatenate([np.full(br.delay, x[0] * 0.0), x[: -br.delay]])
                if br.f is not None:
                    x = br.f(x)
                s += br.h1.filter(x)
            if out.g is not None:
                s = out.g(s)
            if out.h2 is not None:
                s = out.h2.filter(s)
            y[:, j] = s + out.offset
        return y

    def check_limits(self) -> None:
        """Raise ModelError naming the first limit of the firmware this structure exceeds."""
        if not 1 <= len(self.inputs) <= MAX_INPUTS:
            raise ModelError(f"{len(self.inputs)} inputs; the firmware takes 1 to {MAX_INPUTS}")
        if not 1 <= len(self.outputs) <= MAX_OUTPUTS:
            raise ModelError(f"{len(self.outputs)} outputs; the firmware takes 1 to {MAX_OUTPUTS}")
        for out in self.outputs:
            blocks = [(f"{out.name}.g", out.g), (f"{out.name}.h2", out.h2)]
            for br in out.branches:
                blocks += [(f"{out.name}.f[{br.input}]", br.f), (f"{out.name}.h1[{br.input}]", br.h1)]
                if not 0 <= br.delay <= MAX_DELAY:
                    raise ModelError(f"{out.name}: input delay {br.delay} outside 0..{MAX_DELAY}")
            for name, block in blocks:
                if isinstance(block, PiecewiseLinear) and len(block.x) > MAX_BREAKPOINTS:
                    raise ModelError(f"{name}: {len(block.x)} breakpoints; at most {MAX_BREAKPOINTS}")
                if isinstance(block, SOSCascade) and block.n_sections > MAX_SECTIONS:
                    raise ModelError(f"{name}: {2 * block.n_sections} poles; at most {2 * MAX_SECTIONS}")
