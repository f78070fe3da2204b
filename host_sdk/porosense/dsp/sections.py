"""Pure delays in cascades of second-order sections.

A section row is ``[b0, b1, b2, 1, a1, a2]`` (coefficients of z^-1, scipy's sos form). scipy's
tf2sos and zpk2sos drop leading zeros of a numerator; these keep them as whole samples of delay.
"""

from __future__ import annotations

import numpy as np

#: A section that only delays by one sample: z^-1.
DELAY_SECTION = (0.0, 1.0, 0.0, 1.0, 0.0, 0.0)


def split_delay(b) -> tuple[int, np.ndarray]:
    """Leading zeros of a numerator as a pure delay.

    Parameters
    ----------
    b : array_like
        Numerator coefficients of z^-1 in ascending powers, not all zero.

    Returns
    -------
    delay : int
        Number of leading zeros (samples of delay).
    rest : numpy.ndarray
        ``b`` without them.
    """
    b = np.asarray(b, dtype=float)
    delay = int(np.argmax(b != 0))
    return delay, b[delay:]


def fold_delay(sos, delay: int) -> np.ndarray:
    """Put ``delay`` samples of pure delay into second-order sections.

    Each sample of delay shifts the numerator of the last section whose b2 is free (zero) by one
    place; when none is free, a delay section (z^-1) is appended.

    Parameters
    ----------
    sos : array_like, (n_sections, 6)
        Section rows ``[b0, b1, b2, 1, a1, a2]``.
    delay : int
        Samples of delay to add (>= 0).

    Returns
    -------
    numpy.ndarray, (n_sections or more, 6)
        The rows with the delay folded in (a new array).
    """
    sos = np.array(sos, dtype=float)
    for _ in range(int(delay)):
        free = np.flatnonzero(sos[:, 2] == 0)
        if len(free):
            i = free[-1]
            sos[i, :3] = [0.0, sos[i, 0], sos[i, 1]]
        else:
            sos = np.vstack([sos, DELAY_SECTION])
    return sos
