"""Bit-exact Python twin of the firmware estimator (firmware/lib/core/estimator.cpp).

Every rounding, shift and saturation is the firmware's: ``round(v / 2^s)`` is
``(v + 2^(s-1)) >> s`` (ties up), products are exact integers, states saturate at
+-2^28 (Q13 of an int16). ``run`` processes one block at a time over the whole record
(numerators vectorised with numpy, the recursions in a tight integer loop), ``step`` one
sample; both carry the same state, so any mix of calls gives the firmware's sequence.
"""

from __future__ import annotations

import numpy as np

from porosense.errors import InputError
from porosense.protocol.model_blob import STATE_FRAC, STATE_MAX, STATE_MIN, ModelBlob, PwlQ, SectionQ

DELAY_LEN = 16
SATURATED = 0x01


def _round_shift(v: np.ndarray, s: int) -> np.ndarray:
    return v if s == 0 else (v + (1 << (s - 1))) >> s


def pwl_eval(p: PwlQ, x: np.ndarray, sat: np.ndarray) -> np.ndarray:
    """Evaluate a table on int64 inputs; marks saturated samples in ``sat`` (bool)."""
    xs = np.asarray(p.x, dtype=np.int64)
    k = np.clip(np.searchsorted(xs, x, side="right") - 1, 0, len(xs) - 2)
    if p.compact:
        ys = np.asarray(p.y, dtype=np.int64)
        span, dy, dx = xs[k + 1] - xs[k], ys[k + 1] - ys[k], x - xs[k]
        q = np.minimum((np.abs(dx) * np.abs(dy) + span // 2) // span, 0x10000)
        return _sat16(ys[k] + np.where((dx < 0) != (dy < 0), -q, q), sat)
    slope = np.asarray(p.slope, dtype=np.int64)[k]
    shift = np.asarray(p.shift, dtype=np.int64)[k]
    prod = (x - xs[k]) * slope
    half = np.where(shift > 0, np.left_shift(1, np.maximum(shift - 1, 0)), 0)
    y = np.asarray(p.y, dtype=np.int64)[k] + ((prod + half) >> shift)
    return _sat16(y, sat)


def _sat16(v: np.ndarray, sat: np.ndarray) -> np.ndarray:
    sat |= (v > 32767) | (v < -32768)
    return np.clip(v, -32768, 32767)


def _section(s: SectionQ, x: np.ndarray, xh: tuple[int, int], yh: list[int], sat: np.ndarray) -> np.ndarray:
    """Run one section over the int64 input ``x`` with input history ``xh`` = (x[-1], x[-2])
    and state ``yh`` = [y[-1], y[-2]] (updated in place). Returns the Q13 states y (int64)."""
    ext = np.concatenate([[xh[1], xh[0]], x]).astype(np.int64)
    x0, x1, x2 = ext[2:], ext[1:-1], ext[:-2]
    b0, b1, b2 = s.b
    if s.wide:
        w = ((x0 * b0) >> 16) + ((x1 * b1) >> 16) + ((x2 * b2) >> 16)
    else:
        w = x0 * b0 + x1 * b1 + x2 * b2
    W = _round_shift(w, s.sb).tolist()
    k1, k2 = s.k
    n1, n2 = s.n
    r1, r2 = 1 << (n1 - 1), 1 << (n2 - 1)
    y1, y2 = yh
    out = [0] * len(W)
    flags = []
    hi, lo = STATE_MAX, STATE_MIN
    if s.delta:
        for i, wi in enumerate(W):
            acc = wi + 2 * y1 - y2 + (((y1 - y2) * k1 + r1) >> n1) + ((y2 * k2 + r2) >> n2)
            if acc > hi:
                acc = hi
                flags.append(i)
            elif acc < lo:
                acc = lo
                flags.append(i)
            out[i] = acc
            y2 = y1
            y1 = acc
    else:
        m1, m2 = s.m
        for i, wi in enumerate(W):
            acc = wi + m1 * y1 + m2 * y2 + ((y1 * k1 + r1) >> n1) + ((y2 * k2 + r2) >> n2)
            if acc > hi:
                acc = hi
                flags.append(i)
            elif acc < lo:
                acc = lo
                flags.append(i)
            out[i] = acc
            y2 = y1
            y1 = acc
    yh[0], yh[1] = y1, y2
    if flags:
        sat[flags] = True
    return np.asarray(out, dtype=np.int64)


class FixedPointEstimator:
    """The firmware's estimator, bit for bit, on a model blob.

    Parameters
    ----------
    blob : ModelBlob or bytes
        The model; bytes are parsed and checked as the firmware does (``ModelBlob.from_bytes``).

    Raises
    ------
    ModelError
        Bytes that are not a valid blob.
    """

    def __init__(self, blob: ModelBlob | bytes):
        self.blob = blob if isinstance(blob, ModelBlob) else ModelBlob.from_bytes(blob)
        self.reset()

    @property
    def n_inputs(self) -> int:
        return self.blob.n_inputs

    @property
    def n_outputs(self) -> int:
        return self.blob.n_outputs

    def reset(self) -> None:
        """Zero every filter state and delay line (as after Estimator::reset)."""
        self._hist = np.zeros((3, DELAY_LEN), dtype=np.int64)  # previous 16 inputs, oldest first
        self._xh = []  # per cascade (x[-1], x[-2])
        self._yh = []  # per cascade, per section [y[-1], y[-2]]
        for out in self.blob.outputs:
            for br in out.branches:
                self._xh.append((0, 0))
                self._yh.append([[0, 0] for _ in br.sections])
            if out.h2:
                self._xh.append((0, 0))
                self._yh.append([[0, 0] for _ in out.h2])

    def step(self, dr_centi) -> tuple[np.ndarray, int]:
        """One sample, continuing from the current state.

        Parameters
        ----------
        dr_centi : array_like, shape (n,), n <= 3
            Inputs, dR in 0.01 % (int16).

        Returns
        -------
        estimates : ndarray of int16, shape (3,)
            Outputs, estimate LSB (times ``blob.out_scale`` for output units).
        flags : int
            1 when any node saturated, else 0.
        """
        u = np.zeros((1, 3), dtype=np.int64)
        d = np.asarray(dr_centi, dtype=np.int64).ravel()
        u[0, : len(d)] = d
        y, flags = self.run(u)
        return y[0], int(flags[0])

    def run(self, dr_centi) -> tuple[np.ndarray, np.ndarray]:
        """Run on a series of inputs, continuing from the current state.

        Parameters
        ----------
        dr_centi : array_like, shape (N, k), n_inputs <= k <= 3, or (N,)
            Inputs, dR in 0.01 % (int16).

        Returns
        -------
        estimates : ndarray of int16, shape (N, 3)
            Outputs, estimate LSB (times ``blob.out_scale`` for output units).
        flags : ndarray of uint8, shape (N,)
            1 where any node saturated.

        Raises
        ------
        InputError
            Inputs of another shape or outside int16.
        """
        u = np.asarray(dr_centi)
        if u.ndim == 1:
            u = u[:, None]
        if u.ndim != 2 or u.shape[1] < self.n_inputs or u.shape[1] > 3:
            raise InputError(f"replay inputs must have shape (N, {self.n_inputs}..3), got {u.shape}")
        if np.any(u > 32767) or np.any(u < -32768):
            raise InputError("replay inputs must be int16 (dR in 0.01 %)")
        u = u.astype(np.int64)
        n = u.shape[0]
        est = np.zeros((n, 3), dtype=np.int16)
        sat = np.zeros(n, dtype=bool)
        if n == 0:
            return est, sat.astype(np.uint8)
        ext = np.concatenate([self._hist[: self.n_inputs].T, u[:, : self.n_inputs]], axis=0)
        c = 0
        for j, out in enumerate(self.blob.outputs):
            total = np.zeros(n, dtype=np.int64)
            for br in out.branches:
                start = DELAY_LEN - br.delay
                x = _sat16(ext[start : start + n, br.input] - br.u_offset, sat)
                if br.f is not None:
                    x = pwl_eval(br.f, x, sat)
                total += self._cascade(c, br.sections, x, sat)
                c += 1
            v = _sat16(total >> STATE_FRAC, sat)
            if out.g is not None:
                v = pwl_eval(out.g, v, sat)
            if out.h2:
                v = self._cascade(c, out.h2, v, sat) >> STATE_FRAC
                c += 1
            est[:, j] = _sat16(v + out.offset, sat)
        self._hist[: self.n_inputs] = ext[-DELAY_LEN:].T
        return est, sat.astype(np.uint8)

    def _cascade(self, c: int, sections, x: np.ndarray, sat: np.ndarray) -> np.ndarray:
        xh = self._xh[c]
        self._xh[c] = (int(x[-1]), int(x[-2]) if len(x) > 1 else xh[0])
        y = None
        for s, yh in zip(sections, self._yh[c]):
            prev = (yh[0] >> STATE_FRAC, yh[1] >> STATE_FRAC)
            y = _section(s, x, xh, yh, sat)
            x, xh = y >> STATE_FRAC, prev
        assert y is not None, "a cascade has at least one section"
        return y
