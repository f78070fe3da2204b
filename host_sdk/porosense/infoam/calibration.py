"""Machine and material calibration of the InFoam method (liquid rope coiling).

Extruding a molten filament from a height H above the surface makes it coil. Two measured
relations set the porosity of what is printed:

- coil radius versus nozzle height, ``Rc = a H + b`` (mm), from measured coil radii;
- porosity versus coil geometry, calibrated on weighed cubes.

Coil density ``N`` is the number of coils laid per coil diameter of travel, so the travel
speed is the filament speed divided by ``pi N`` and a coiled line of width ``w = 2 Rc + d``
holds ``pi N`` mm of filament per mm of travel (d: filament diameter = nozzle diameter).
With coiled lines stacked side by side the solid fraction is ``s = c N / (w + e)``: ``c``
(mm) lumps filament cross-section and layer thickness, ``e`` (mm) the gap between lines.
Both are fitted to cubes of known porosity.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy import optimize

from porosense.errors import InputError

#: The paper's measurements: cTPE contractors printed with N = 3 at these heights (mm)...
PAPER_HEIGHTS_MM = (4.0, 6.0, 8.0, 10.0)
#: ...gave these porosities (%).
PAPER_POROSITIES_PCT = (68.0, 76.0, 82.0, 86.0)
PAPER_COIL_DENSITY = 3.0


def porosity_from_mass(mass_g: float, volume_mm3: float, bulk_density_g_cm3: float = 0.97) -> float:
    """Porosity in % of a printed sample: phi = 100 (1 - m / (V rho_b)).

    mass in g, volume in mm^3 (the sample's envelope), bulk density in g/cm^3.
    """
    if mass_g <= 0 or volume_mm3 <= 0 or bulk_density_g_cm3 <= 0:
        raise InputError("mass, volume and bulk density must be positive")
    solid = mass_g / (volume_mm3 * 1e-3 * bulk_density_g_cm3)
    if solid > 1.05:
        raise InputError(f"sample denser than the bulk material ({solid:.2f} x rho_b): check mass, volume and density")
    return 100.0 * (1.0 - min(solid, 1.0))


@dataclass(frozen=True)
class CoilRadiusFit:
    """Rc = a H + b in mm, fitted over heights h_min..h_max (mm); r2 of the fit."""

    a: float
    b: float
    r2: float = 1.0
    h_min_mm: float = 2.5
    h_max_mm: float = 10.0

    def __post_init__(self):
        vals = (self.a, self.b, self.h_min_mm, self.h_max_mm)
        if not all(np.isfinite(v) for v in vals):
            raise InputError(
                f"coil radius fit has a non-finite value: Rc = {self.a} H + {self.b}, "
                f"H {self.h_min_mm}..{self.h_max_mm} mm"
            )
        if not 0.0 < self.h_min_mm < self.h_max_mm:
            raise InputError(
                f"coil radius fit: height range {self.h_min_mm:g}..{self.h_max_mm:g} mm is empty or negative"
            )
        if self.a <= 0:
            raise InputError(f"coil radius must grow with nozzle height (Rc = {self.a:g} H {self.b:+g} mm)")
        r_low = self.a * self.h_min_mm + self.b
        if r_low <= 0:
            raise InputError(
                f"coil radius Rc = {self.a:g} H {self.b:+g} mm is {r_low:.2f} mm at the lowest "
                f"height {self.h_min_mm:g} mm: a coil radius must be positive"
            )

    def radius(self, height_mm):
        """Coil radius (mm) at nozzle height(s) ``height_mm``."""
        return self.a * np.asarray(height_mm, dtype=float) + self.b

    def height(self, radius_mm):
        """Nozzle height (mm) that gives coil radius ``radius_mm``."""
        return (np.asarray(radius_mm, dtype=float) - self.b) / self.a

    @classmethod
    def fit(cls, heights_mm, radii_mm) -> CoilRadiusFit:
        """Least-squares line through measured (height, coil radius) pairs, both in mm."""
        h = np.asarray(heights_mm, dtype=float)
        r = np.asarray(radii_mm, dtype=float)
        if h.shape != r.shape or h.size < 2 or np.ptp(h) == 0:
            raise InputError("need at least two coil-radius measurements at different heights")
        if not (np.all(np.isfinite(h)) and np.all(np.isfinite(r))):
            raise InputError("coil-radius measurements hold NaN or infinite values")
        if np.any(h <= 0) or np.any(r <= 0):
            bad = float(r.min()) if np.any(r <= 0) else float(h.min())
            raise InputError(f"coil radii and heights must be positive (found {bad:g} mm)")
        a, b = np.polyfit(h, r, 1)
        resid = r - (a * h + b)
        ss_tot = float(np.sum((r - r.mean()) ** 2))
        r2 = 1.0 - float(np.sum(resid**2)) / ss_tot if ss_tot > 0 else 1.0
        return cls(float(a), float(b), r2, float(h.min()), float(h.max()))


#: The paper's cTPE calibration (Rc = 0.40 H - 0.3 mm for H from 2.5 to 10 mm).
PAPER_COIL_RADIUS = CoilRadiusFit(0.40, -0.3)


@dataclass(frozen=True)
class PorosityModel:
    """Porosity from coil geometry: solid fraction s = c N / (2 Rc + d + e).

    c and e in mm (fitted), d the nozzle diameter (mm), coil radius from ``coil``.
    """

    c_mm: float
    e_mm: float
    nozzle_mm: float = 0.6
    coil: CoilRadiusFit = PAPER_COIL_RADIUS

    def __post_init__(self):
        if not (np.isfinite(self.c_mm) and self.c_mm > 0 and np.isfinite(self.nozzle_mm) and self.nozzle_mm > 0):
            raise InputError(f"porosity model needs positive c ({self.c_mm}) and nozzle ({self.nozzle_mm}) in mm")
        if (
            not np.isfinite(self.e_mm)
            or 2 * float(self.coil.radius(self.coil.h_min_mm)) + self.nozzle_mm + self.e_mm <= 0
        ):
            raise InputError(f"porosity model: line gap e = {self.e_mm} mm leaves no room between coiled lines")

    def solid_fraction(self, height_mm, coil_density=PAPER_COIL_DENSITY):
        """Solid volume fraction (0..1) at nozzle height (mm) and coil density N."""
        w = 2.0 * self.coil.radius(height_mm) + self.nozzle_mm
        return np.clip(self.c_mm * np.asarray(coil_density, float) / (w + self.e_mm), 0.0, 1.0)

    def porosity(self, height_mm, coil_density=PAPER_COIL_DENSITY):
        """Porosity in % at nozzle height (mm) and coil density N."""
        return 100.0 * (1.0 - self.solid_fraction(height_mm, coil_density))

    def height_for(self, porosity_pct: float, coil_density: float = PAPER_COIL_DENSITY) -> float:
        """Nozzle height (mm) that prints ``porosity_pct`` at coil density N.

        Raises InputError when it lies outside the calibrated height range.
        """
        s = 1.0 - porosity_pct / 100.0
        if s <= 0:
            raise InputError(f"porosity {porosity_pct} % is not printable")
        w = self.c_mm * coil_density / s - self.e_mm
        h = float(self.coil.height((w - self.nozzle_mm) / 2.0))
        lo, hi = self.coil.h_min_mm, self.coil.h_max_mm
        if not lo - 1e-9 <= h <= hi + 1e-9:
            p_lo, p_hi = self.porosity(lo, coil_density), self.porosity(hi, coil_density)
            raise InputError(
                f"porosity {porosity_pct:.1f} % needs a nozzle height of {h:.2f} mm, outside the "
                f"calibrated {lo:g}-{hi:g} mm (coiling at N = {coil_density:g} gives "
                f"{p_lo:.1f}-{p_hi:.1f} %); change N or print it conventionally"
            )
        return h

    def coil_density_for(self, porosity_pct: float, height_mm: float) -> float:
        """Coil density N that prints ``porosity_pct`` at nozzle height ``height_mm`` (mm)."""
        s = 1.0 - porosity_pct / 100.0
        w = 2.0 * float(self.coil.radius(height_mm)) + self.nozzle_mm
        return s * (w + self.e_mm) / self.c_mm

    def line_width(self, height_mm) -> float:
        """Pitch (mm) between neighbouring coiled lines: coil width plus gap."""
        return float(2.0 * self.coil.radius(height_mm) + self.nozzle_mm + self.e_mm)

    @classmethod
    def fit(
        cls,
        heights_mm,
        porosities_pct,
        coil_densities=PAPER_COIL_DENSITY,
        *,
        nozzle_mm: float = 0.6,
        coil: CoilRadiusFit = PAPER_COIL_RADIUS,
    ) -> PorosityModel:
        """Fit c and e (mm) to cubes printed at known heights (mm) and coil densities."""
        h = np.asarray(heights_mm, dtype=float)
        phi = np.asarray(porosities_pct, dtype=float)
        n = np.broadcast_to(np.asarray(coil_densities, dtype=float), h.shape)
        if h.size < 2 or h.shape != phi.shape:
            raise InputError("need at least two cubes with matching heights and porosities")
        if np.any((phi <= 0) | (phi >= 100)):
            raise InputError("porosities must lie strictly between 0 and 100 %")
        s = 1.0 - phi / 100.0
        w = 2.0 * coil.radius(h) + nozzle_mm

        def resid(p):
            c, e = p
            return 100.0 * (c * n / (w + e) - s)

        # Start from e = 0: c is then the mean of s w / N.
        c0 = float(np.mean(s * w / n))
        sol = optimize.least_squares(resid, [c0, 0.0], bounds=([1e-6, -float(w.min()) + 1e-3], [np.inf, np.inf]))
        return cls(float(sol.x[0]), float(sol.x[1]), nozzle_mm, coil)

    def to_dict(self) -> dict:
        return asdict(self)


def paper_calibration() -> PorosityModel:
    """The porosity model calibrated on the paper's four contractors (N = 3)."""
    return PorosityModel.fit(PAPER_HEIGHTS_MM, PAPER_POROSITIES_PCT, PAPER_COIL_DENSITY)
