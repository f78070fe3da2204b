"""A model's blocks as MATLAB variables (``export --mat``): numerators, denominators, breakpoints, Ts.

The file holds one struct ``porosense_model`` (v5 .mat, read by ``load`` in MATLAB and Octave):

    Ts, TimeUnit ('seconds'), InputName, InputUnit, OutputName, OutputUnit   (cell arrays of text)
    outputs{j}      one struct per output:
        Name, Kind ('linear' | 'hammerstein' | 'wiener' | 'wh'), Offset
        H1_num{i}, H1_den{i}, H1_delay(i), U_offset(i)   the linear block of input i (delay in samples)
        F_x{i}, F_y{i}                                    input i's static map (empty: none)
        G_x, G_y                                          the static map after the sum (empty: none)
        H2_num, H2_den                                    the output's linear block (empty: none)

Numerators and denominators have equal length, so they read the same as powers of z^-1
(``filter(num, den, u)``) and as powers of z (``idtf(num, den, Ts)``). Static maps are linear
between breakpoints and extend their outer segments (``interp1(x, y, u, 'linear', 'extrap')``).
The output is ``H2(G(sum_i H1_i(F_i(delayed(u_i - U_offset_i))))) + Offset``, simulated from rest
(the delay shifts in zeros before F):
docs/matlab.md rebuilds it in MATLAB, as ``idtf``/``idnlhw`` objects and as plain filtering.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from porosense.files import atomic_path


def _equal_length(b, a) -> tuple[np.ndarray, np.ndarray]:
    b, a = np.atleast_1d(np.asarray(b, float)), np.atleast_1d(np.asarray(a, float))
    n = max(len(b), len(a))
    return np.pad(b, (0, n - len(b))), np.pad(a, (0, n - len(a)))


def _cell(items) -> np.ndarray:
    out = np.empty((len(items), 1), dtype=object)
    for k, item in enumerate(items):
        out[k, 0] = item
    return out


def _row(values) -> np.ndarray:
    return np.asarray(values, dtype=float).reshape(1, -1)


def matlab_variables(model) -> dict:
    """The variables ``export --mat`` writes, as a dict for ``scipy.io.savemat``.

    Parameters
    ----------
    model
        An identified model or model set (anything with ``to_structure()``).

    Returns
    -------
    dict
        ``{"porosense_model": struct}`` with the fields listed in the module's note.
    """
    s = model.to_structure()
    outputs = []
    for chain in s.outputs:
        h1_num, h1_den, delays, offsets, f_x, f_y = [], [], [], [], [], []
        by_input = {br.input: br for br in chain.branches}
        for i in range(len(s.inputs)):
            br = by_input.get(i)
            if br is None:  # an input this output does not use: a zero block
                h1_num.append(_row([0.0]))
                h1_den.append(_row([1.0]))
                delays.append(0.0)
                offsets.append(0.0)
                f_x.append(np.zeros((0, 0)))
                f_y.append(np.zeros((0, 0)))
                continue
            b, a = _equal_length(*br.h1.to_tf())
            h1_num.append(_row(b))
            h1_den.append(_row(a))
            delays.append(float(br.delay))
            offsets.append(float(br.u_offset))
            f_x.append(_row(br.f.x) if br.f is not None else np.zeros((0, 0)))
            f_y.append(_row(br.f.y) if br.f is not None else np.zeros((0, 0)))
        h2 = _equal_length(*chain.h2.to_tf()) if chain.h2 is not None else (np.zeros(0), np.zeros(0))
        outputs.append(
            {
                "Name": chain.name,
                "Kind": chain.kind,
                "Offset": float(chain.offset),
                "H1_num": _cell(h1_num),
                "H1_den": _cell(h1_den),
                "H1_delay": _row(delays),
                "U_offset": _row(offsets),
                "F_x": _cell(f_x),
                "F_y": _cell(f_y),
                "G_x": _row(chain.g.x) if chain.g is not None else np.zeros((0, 0)),
                "G_y": _row(chain.g.y) if chain.g is not None else np.zeros((0, 0)),
                "H2_num": _row(h2[0]) if h2[0].size else np.zeros((0, 0)),
                "H2_den": _row(h2[1]) if h2[1].size else np.zeros((0, 0)),
            }
        )
    units_in = [u or "" for u in (s.input_units or ())] + [""] * (len(s.inputs) - len(s.input_units or ()))
    units_out = [u or "" for u in (s.output_units or ())] + [""] * (len(s.outputs) - len(s.output_units or ()))
    return {
        "porosense_model": {
            "Ts": float(s.ts),
            "TimeUnit": "seconds",
            "InputName": _cell(list(s.inputs)),
            "InputUnit": _cell(units_in),
            "OutputName": _cell([c.name for c in s.outputs]),
            "OutputUnit": _cell(units_out),
            "outputs": _cell(outputs),
        }
    }


def write_mat(model, path) -> Path:
    """Write :func:`matlab_variables` of ``model`` to the .mat file ``path`` (whole or not at all)."""
    from scipy.io import savemat

    path = Path(path)
    with atomic_path(path) as tmp:
        savemat(tmp, matlab_variables(model), format="5", oned_as="row")
    return path


def simulate_variables(variables: dict, u) -> np.ndarray:
    """Simulate the exported variables on ``u`` (N, n_inputs) as MATLAB would (filter and interp1).

    Written from the file's description alone, for checking an export: (N, n_outputs)."""
    from scipy.signal import lfilter

    m = variables["porosense_model"]
    u = np.asarray(u, float).reshape(len(u), -1)
    ys = []
    for out in np.ravel(m["outputs"]):
        total = np.zeros(len(u))
        for i in range(u.shape[1]):
            x = u[:, i] - np.ravel(out["U_offset"])[i]
            d = int(np.ravel(out["H1_delay"])[i])
            if d:
                x = np.concatenate([np.zeros(d), x[:-d]])
            fx, fy = np.ravel(np.ravel(out["F_x"])[i]), np.ravel(np.ravel(out["F_y"])[i])
            if fx.size:
                x = _interp_extrap(x, fx, fy)
            total += lfilter(np.ravel(np.ravel(out["H1_num"])[i]), np.ravel(np.ravel(out["H1_den"])[i]), x)
        gx, gy = np.ravel(out["G_x"]), np.ravel(out["G_y"])
        if gx.size:
            total = _interp_extrap(total, gx, gy)
        if np.size(out["H2_num"]):
            total = lfilter(np.ravel(out["H2_num"]), np.ravel(out["H2_den"]), total)
        ys.append(total + float(np.ravel(out["Offset"])[0]))
    return np.column_stack(ys)


def _interp_extrap(x, bx, by) -> np.ndarray:
    """interp1(bx, by, x, 'linear', 'extrap')."""
    y = np.interp(x, bx, by)
    lo, hi = x < bx[0], x > bx[-1]
    y[lo] = by[0] + (x[lo] - bx[0]) * (by[1] - by[0]) / (bx[1] - bx[0])
    y[hi] = by[-1] + (x[hi] - bx[-1]) * (by[-1] - by[-2]) / (bx[-1] - bx[-2])
    return y
