"""Piezoresistance of the conductive foam.

Chain from the actuator strain ``eps`` (fraction) to dR (%):

1. pore-contact strain ``eps_c``: the contacts inside the foam lag the strain the markers see
   (lead-lag ``(1 + lead s) / (1 + lag s)``), a linear dynamic block; a hanging load's tension,
   carried by the cell walls, holds contacts open (``eps_c`` lower by
   ``load_contact_coupling * sigma_load / E``), which changes the dR-strain map under load;
2. contact formation (static, the pore collapse nonlinearity): compression closes tunnelling
   gaps in proportion to the collapsed share of the pore space, ``n = eps_c / capacity``
   (capacity = the actuator's strain capacity), ``dR = -D (1 - exp(-(n / n0)^q))``, where D
   (< 100 %) leaves the resistance of the densified network and the electrodes; tension
   (a load stretching the foam) raises R with a gauge factor;
3. network relaxation: after a change the carbon-black network slowly re-forms, so dR first
   overshoots and then relaxes: ``dR = g + k (g - LP(g))`` with a first-order LP of time
   constant ``relax_s`` (optionally scaled by ``R/R0 = 1 + g/100``, ``relax_r_scaling``).
   After a release this puts R above R0, decaying before the next cycle.

Seen from dR to strain (what the estimator identifies) the chain is Wiener-Hammerstein: the
inverse relaxation (linear), the inverse contact curve (static), the inverse contact lag
(linear). Relaxation makes the loops rate dependent; the contact curve gives the static
nonlinearity of pore collapse.
"""

from __future__ import annotations

import math

import numpy as np

from porosense.sim.params import Piezo


def contact_dr(eps_c, p: Piezo, capacity: float):
    """Static dR (%) of the contact network at contact strain ``eps_c`` (fraction).

    ``capacity`` is the actuator's strain capacity (fraction, :attr:`FoamCurve.capacity`):
    contacts close with the collapsed share of the pore space, ``n = eps_c / capacity``.
    """
    e = np.asarray(eps_c, dtype=float)
    x = (np.maximum(e, 0.0) / (capacity * p.contact_strain)) ** p.contact_exponent
    out = np.where(e >= 0.0, p.floor_pct * np.expm1(-x), -100.0 * p.tension_gauge_factor * e)
    return float(out) if out.ndim == 0 else out


def contact_dr_scalar(e: float, p: Piezo, capacity: float) -> float:
    """:func:`contact_dr` for one float (plant stepping)."""
    if e < 0.0:
        return -100.0 * p.tension_gauge_factor * e
    return p.floor_pct * math.expm1(-((e / (capacity * p.contact_strain)) ** p.contact_exponent))
