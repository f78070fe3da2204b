"""Expected stroke and sensitivity of a design at each vacuum level, from the simulator."""

from __future__ import annotations

from dataclasses import asdict, dataclass

from porosense.infoam.design import Design

PAPER_VACUUM_KPA = (-10.0, -20.0, -40.0, -60.0)


@dataclass(frozen=True)
class PredictionRow:
    """Steady state at one vacuum level: kPa, %, 1/m; None where the actuator has no such output."""

    vacuum_kpa: float
    dR_pct: float
    strain_pct: float | None
    curvature_1pm: float | None


@dataclass(frozen=True)
class Prediction:
    """A design's foam porosity (%) and its steady-state response per vacuum level."""

    design: str
    actuator: str
    foam_porosity: float
    load_g: float
    rows: tuple[PredictionRow, ...]

    def to_dict(self) -> dict:
        return asdict(self)

    def summary(self) -> list[str]:
        lines = [f"{self.design} ({self.actuator}): foam porosity {self.foam_porosity:.1f} %, load {self.load_g:g} g"]
        for r in self.rows:
            out = (
                f"strain {r.strain_pct:6.2f} %" if r.strain_pct is not None else f"curvature {r.curvature_1pm:6.2f} 1/m"
            )
            lines.append(f"  {r.vacuum_kpa:6.1f} kPa: dR {r.dR_pct:7.2f} %, {out}")
        return lines


def predict(design: Design, *, load_g: float = 0.0, vacuum_kpa=PAPER_VACUUM_KPA) -> Prediction:
    """Run the simulator's steady-state model at the design's foam porosity for each vacuum (kPa)."""
    from porosense.sim import steady_state

    phi = design.foam_porosity()
    rows = []
    for p in vacuum_kpa:
        ss = steady_state(design.actuator, porosity=phi, load_g=load_g, vacuum_kpa=p)
        curvature = _opt(ss, "curvature_per_m")
        strain = None if curvature is not None else _opt(ss, "strain_pct")
        rows.append(PredictionRow(float(p), float(ss["dR_pct"]), strain, curvature))
    return Prediction(design.name, design.actuator, phi, load_g, tuple(rows))


def _opt(d: dict, key: str) -> float | None:
    v = d.get(key)
    return None if v is None else float(v)
