"""Test oracle: the CSV line mode (LINE_MODE) written independently of the firmware's
firmware/lib/core/standalone_out.cpp, which must produce these lines byte for byte.

Columns: t_ms (device ms), dR of each streamed channel in % with 2 decimals (dr_centi exact),
then each model output in its unit with 3 decimals: est * out_scale * 1000 computed exactly
(out_scale being the model header's float32), rounded half away from zero, saturated at +-2e9. Lines end with CR LF; a header names the columns.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np


def format_header(dr_mask: int, n_est: int) -> bytes:
    """``t_ms,dR0,dR1,dR2,est0,...`` for the channels in ``dr_mask`` and ``n_est`` outputs."""
    names = ["t_ms"] + [f"dR{ch}" for ch in range(3) if dr_mask >> ch & 1] + [f"est{j}" for j in range(min(n_est, 3))]
    return (",".join(names) + "\r\n").encode()


def estimate_milli(estimate: int, out_scale: float) -> int:
    """Estimate in output units times 1000, exact, rounded half away from zero, saturated."""
    v = Fraction(int(estimate)) * Fraction(float(np.float32(out_scale))) * 1000
    r = int(abs(v) + Fraction(1, 2))  # floor of |v| + 1/2
    r = min(r, 2_000_000_000)
    return -r if v < 0 else r


def _fixed(v: int, decimals: int) -> str:
    sign = "-" if v < 0 else ""
    digits = str(abs(int(v))).rjust(decimals + 1, "0")
    return sign + (digits[:-decimals] + "." + digits[-decimals:] if decimals else digits)


def format_line(t_ms: int, dr_mask: int, dr_centi, n_est: int, estimate, out_scale) -> bytes:
    """One line of the firmware's line mode."""
    cols = [str(int(t_ms) & 0xFFFFFFFF)]
    cols += [_fixed(int(dr_centi[ch]), 2) for ch in range(3) if dr_mask >> ch & 1]
    cols += [_fixed(estimate_milli(int(estimate[j]), float(out_scale[j])), 3) for j in range(min(n_est, 3))]
    return (",".join(cols) + "\r\n").encode()
