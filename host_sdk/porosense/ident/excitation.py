"""What cannot be a model, refused before any fit: an input that is the output, an input with no variation.

A model of an output from itself fits 100 % and means nothing; a model from a constant input
fits the output's mean (0 %) and means nothing either. Both used to be saved.

"No variation" needs a scale: an input varies too little when its range is below one count of
a 16-bit converter over its own magnitude (``range < max|u| / 2**16``). That is the resolution
of the board's ADS1115 and of most lab recorders; a smaller variation is below what any of them
measures, so whatever it holds is rounding, not excitation. (An input varying by less than this
does not make a model; one varying by more may still be poorly excited: identification then says
so through its fits.)
"""

from __future__ import annotations

import numpy as np

from porosense.errors import InputError

CONVERTER_COUNTS = 2**16  # one count of a 16-bit converter: the smallest variation a record can measure


def variation_floor(values) -> float:
    """The smallest range (in the values' unit) that is a measured variation: max|u| / 2**16."""
    return float(np.max(np.abs(values))) / CONVERTER_COUNTS if np.size(values) else 0.0


def check_identifiable(us, ys, inputs, outputs) -> None:
    """Raise InputError when ``us``/``ys`` cannot make a model (see the module's note).

    Parameters
    ----------
    us : list of (N_k, n_inputs) arrays
        The estimation inputs of every record, in the data's units.
    ys : list of (N_k,) or (N_k, n_outputs) arrays
        The estimation outputs of every record.
    inputs, outputs : list of str
        Column names, for the message.

    Raises
    ------
    InputError
        An input named as an output; an input equal to an output sample for sample; an input or
        an output whose range over every record is below one 16-bit count of its magnitude.
    """
    same = [c for c in inputs if c in outputs]
    if same:
        raise InputError(
            f"column '{same[0]}' is both an input and an output: a model of a signal from itself fits 100 % "
            "and means nothing"
        )
    u = np.concatenate([np.asarray(x, float).reshape(len(x), -1) for x in us])
    y = np.concatenate([np.asarray(x, float).reshape(len(x), -1) for x in ys])
    for i, name in enumerate(inputs):
        for j, out in enumerate(outputs):
            if np.array_equal(u[:, i], y[:, j]):
                raise InputError(
                    f"input '{name}' equals output '{out}' sample for sample: a model of a signal from "
                    "a copy of itself means nothing"
                )
    for what, names, data in (("input", inputs, u), ("output", outputs, y)):
        for k, name in enumerate(names):
            column = data[:, k]
            span = float(np.ptp(column))
            floor = variation_floor(column)
            if span == 0.0 or span < floor:
                level = (
                    f"is constant at {column[0]:g}"
                    if span == 0.0
                    else f"varies by only {span:.3g} around {np.mean(column):.6g}"
                )
                raise InputError(
                    f"{what} '{name}' {level} over the estimation data (below one count of a 16-bit converter, "
                    f"{floor:.3g}): {'it excites nothing' if what == 'input' else 'there is nothing'} to identify"
                )
