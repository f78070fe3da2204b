"""Foam mechanics: static collapse curve and viscoelastic creep of a porous contractor.

Static curve: strain (fraction of the unloaded length, positive when the actuator shortens)
against the axial compressive stress ``sigma`` (kPa) for porosity ``phi`` (%), relative
density ``rho = 1 - phi/100``, densification strain ``eps_D = 1 - 1.4 rho`` (Gibson-Ashby):

- cell-wall bending, stiffening towards densification:
  ``a eps_D (1 - exp(-sigma / (E a eps_D)))`` with ``E = E_s rho^2`` (Gibson-Ashby, open
  cells), i.e. initial slope ``1/E`` and an asymptote ``a eps_D``;
- elastic collapse (buckling) of the pores around ``sigma_c = sigma_ref (rho/rho_ref)^1.5``,
  spread over ``width * sigma_c`` by the graded porosity (a logistic step normalised to 0 at
  rest and 1 when fully collapsed), releasing ``c eps_D``.

Tension (a hanging load at rest) is linear with modulus ``tension_stiffening * E``. Creep:
the strain follows the static curve through parallel first-order modes (``creep_tau_s``,
``creep_weight``), a linear viscoelastic (Prony series) model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from porosense.sim.params import Foam

G_ACCEL = 9.81  # m/s^2


@dataclass(frozen=True)
class FoamCurve:
    """The static strain-stress curve of one porosity, ready to evaluate."""

    modulus_kpa: float  # E = E_s rho^2
    tension_kpa: float  # modulus under tension
    collapse_kpa: float  # centre of the collapse regime
    width_kpa: float  # spread of the collapse regime
    bending_strain: float  # asymptote of the wall-bending strain, a eps_D
    collapse_strain: float  # strain released by a full collapse, c eps_D
    step0: float  # logistic value at sigma = 0 (normalisation)

    @classmethod
    def of(cls, porosity: float, p: Foam) -> FoamCurve:
        rho = 1.0 - porosity / 100.0
        rho_ref = 1.0 - p.ref_porosity / 100.0
        collapse = p.collapse_kpa_ref * (rho / rho_ref) ** p.collapse_exponent
        eps_d = 1.0 - 1.4 * rho
        width = p.collapse_width * collapse
        modulus = p.solid_modulus_kpa * rho**2
        return cls(
            modulus_kpa=modulus,
            tension_kpa=p.tension_stiffening * modulus,
            collapse_kpa=collapse,
            width_kpa=width,
            bending_strain=p.bending_scale * eps_d,
            collapse_strain=p.collapse_scale * eps_d,
            step0=1.0 / (1.0 + math.exp(collapse / width)),
        )

    @property
    def capacity(self) -> float:
        """Strain capacity (fraction): the limit of the curve at large stress."""
        return self.bending_strain + self.collapse_strain

    def strain(self, sigma_kpa):
        """Static strain (fraction) at compressive stress ``sigma_kpa`` (array or float)."""
        s = np.asarray(sigma_kpa, dtype=float)
        sc = np.maximum(s, 0.0)
        step = (1.0 / (1.0 + np.exp(-(sc - self.collapse_kpa) / self.width_kpa)) - self.step0) / (1.0 - self.step0)
        a = self.bending_strain
        compressed = -a * np.expm1(-sc / (self.modulus_kpa * a)) + self.collapse_strain * step
        out = np.where(s >= 0.0, compressed, s / self.tension_kpa)
        return float(out) if out.ndim == 0 else out

    def slope(self, sigma_kpa):
        """d strain / d stress (1/kPa) at ``sigma_kpa`` (array or float)."""
        s = np.asarray(sigma_kpa, dtype=float)
        sc = np.maximum(s, 0.0)
        lg = 1.0 / (1.0 + np.exp(-(sc - self.collapse_kpa) / self.width_kpa))
        compressed = np.exp(
            -sc / (self.modulus_kpa * self.bending_strain)
        ) / self.modulus_kpa + self.collapse_strain * lg * (1.0 - lg) / self.width_kpa / (1.0 - self.step0)
        out = np.where(s >= 0.0, compressed, 1.0 / self.tension_kpa)
        return float(out) if out.ndim == 0 else out

    def slope_scalar(self, s: float) -> float:
        """:meth:`slope` for one float."""
        if s < 0.0:
            return 1.0 / self.tension_kpa
        e = (s - self.collapse_kpa) / self.width_kpa
        lg = 1.0 / (1.0 + math.exp(-e)) if e > -700 else 0.0
        return math.exp(
            -s / (self.modulus_kpa * self.bending_strain)
        ) / self.modulus_kpa + self.collapse_strain * lg * (1.0 - lg) / self.width_kpa / (1.0 - self.step0)

    def strain_scalar(self, s: float) -> float:
        """Same as :meth:`strain` for one float, without numpy overhead (plant stepping)."""
        if s < 0.0:
            return s / self.tension_kpa
        e = (s - self.collapse_kpa) / self.width_kpa
        step = (1.0 / (1.0 + math.exp(-e)) - self.step0) / (1.0 - self.step0) if e > -700 else 0.0
        a = self.bending_strain
        return -a * math.expm1(-s / (self.modulus_kpa * a)) + self.collapse_strain * step


def load_stress_kpa(load_g, p: Foam):
    """Axial tensile stress (kPa, in chamber-vacuum units) the foam carries of a hanging load of
    ``load_g`` grams (the sleeve carries the rest, ``1 - load_share``)."""
    return p.load_share * np.asarray(load_g, dtype=float) * 1e-3 * G_ACCEL / (p.load_area_mm2 * 1e-6) / 1e3
