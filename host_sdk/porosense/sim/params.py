"""Parameters of the physical chain, one dataclass per stage, with units and sources.

Defaults reproduce the paper (docs/design.md, last section; the tests in tests/sim state each
figure and its bound): contractors of 76-86 % porosity strain 15-35 % with dR of -75 to -95 %
at -60 kPa, pores collapse between about -10 and -40 kPa, the hysteresis is rate dependent,
the resistance overshoots above R0 after a release and relaxes before the next cycle, and
identifying on the paper's experiments gives the paper's fits (WH about 83 %, linear about
76 %). Where the paper gives no number for a parameter, its value was chosen so that the
simulated experiments give the paper's figures, and the docstring says which figure.

Each effect beyond a Wiener-Hammerstein chain is named in :data:`PHYSICS_EFFECTS` and can be
switched off with :meth:`Physics.without`.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from porosense.errors import InputError


@dataclass(frozen=True)
class Pneumatics:
    """Regulated vacuum line, valve and chamber of one channel.

    ``regulator_noise_kpa`` (kPa rms) with correlation time ``regulator_noise_s`` (s): the
    pressure the regulator holds wanders while the pump runs. The paper names no regulator;
    0.25 kPa is half of the +-0.5 % of a 100 kPa span that proportional vacuum regulators
    typically state for repeatability, read as one standard deviation.
    """

    tau_fill_s: float = 0.25  # chamber evacuation time constant through the open valve
    tau_vent_s: float = 0.12  # vent-to-atmosphere time constant (valve closed)
    tau_leak_s: float = 3.0  # line losing vacuum when the pump is off but the valve is open
    max_rate_kpa_s: float = 180.0  # flow limit: largest |dp/dt| the pump and vent can sustain
    min_setpoint_kpa: float = -80.0  # regulator range
    regulator_noise_kpa: float = 0.25
    regulator_noise_s: float = 0.5


@dataclass(frozen=True)
class Foam:
    """Porous conductive TPE under vacuum (Gibson-Ashby scaling in relative density 1 - phi/100).

    The collapse between about -10 and -40 kPa and the strain ranges per porosity are the
    paper's (Fig. 3: 15-35 % strain at -60 kPa for 76-86 %); the solid modulus is that of a
    Shore 70A TPE (TC7OEX-BLCK, the paper's pellets).
    """

    solid_modulus_kpa: float = 12000.0  # E_s of the carbon-black TPE; foam E = E_s (1 - phi/100)^2
    tension_stiffening: float = 4.0  # modulus in tension (aligned struts, rings) / E
    collapse_kpa_ref: float = 20.0  # collapse stress of the reference porosity (kPa)
    collapse_exponent: float = 1.5  # Gibson-Ashby collapse stress ~ (1 - phi/100)^1.5
    ref_porosity: float = 86.0  # porosity (%) the collapse stress refers to
    collapse_width: float = 0.35  # spread of the collapse (graded porosity), x collapse stress
    bending_scale: float = 0.40  # wall-bending strain asymptote, x densification strain
    collapse_scale: float = 0.20  # strain released by full collapse, x densification strain
    load_area_mm2: float = 346.0  # chamber cross-section the vacuum and a load act on (21 mm)
    load_share: float = 0.6  # share of a hanging load the foam carries (the sealed sleeve the rest)
    creep_tau_s: tuple = (0.05, 0.35, 1.2)  # viscoelastic creep modes (time constants)
    creep_weight: tuple = (0.75, 0.17, 0.08)  # their share of the static strain (sum 1)


@dataclass(frozen=True)
class Piezo:
    """Piezoresistance of the carbon-black network (porosense.sim.material): contacts close
    as pores collapse.

    Static law: the paper's dR beyond -80 % at 20-30 % strain (contractors 90+ %) and its
    sensitivity falling as contacts saturate set ``floor_pct``, ``contact_strain`` and
    ``contact_exponent``. Dynamics: the paper's rate-dependent loops (a -10 kPa step shows
    more loop area than the slow staircase), the overshoot above R0 after a release that
    relaxes before the next 10 s cycle, and its fits (WH about 83 %, linear about 76 %: what
    a WH model cannot capture) set the kinetics, the two relaxation modes, the softening and
    the noise; the paper states none of them as a number.
    """

    r0_ohm: float = 2200.0  # resistance of the unloaded actuator at rest
    contact_strain: float = 0.33  # collapsed share of the strain capacity closing 63 % of the contacts
    contact_exponent: float = 1.4  # shape of the contact-formation curve (> 1: slow start)
    floor_pct: float = 97.0  # largest static resistance drop D (%): densified network + electrodes
    tension_gauge_factor: float = 2.0  # dR/R per unit tensile strain (load pulling the foam)
    load_contact_coupling: float = 1.0  # contacts held open by a load: strain offset, x sigma_load / E
    instant_share: float = 0.3  # share of the contact change that follows the strain at once
    form_s: float = 0.6  # contact formation time constant (s), while pores collapse
    break_s: float = 1.5  # contact breaking time constant (s), while pores reopen
    soften_fraction: float = 0.10  # sensitivity lost by a fully conditioned network (Mullins)
    soften_cycles: float = 1.0  # full loading paths (0 -> all contacts) that condition 63 %
    soften_heal_s: float = 60.0  # the network recovers its sensitivity (s)
    relax_s: tuple = (0.7, 3.0)  # network relaxation time constants (s)
    relax_gain: tuple = (0.20, 0.12)  # their gains (log domain: release overshoot ~ exp(k |h|) - 1)
    relax_log: bool = True  # relaxation proportional to R (log domain) instead of additive in dR
    noise_pct: float = 0.08  # white contact noise, dR % rms
    flicker_pct: float = 0.10  # slow contact noise (first-order, flicker_s), dR % rms
    flicker_s: float = 2.0
    curve_strain: tuple = ()  # a measured static curve (material calibration): strains (fraction) ...
    curve_log_r: tuple = ()  # ... and the settled ln(R / R0) there, replacing the contact curve


@dataclass(frozen=True)
class Electronics:
    """Divider (5 V -> bias -> node -> sensor -> GND) and ADS1115.

    The firmware configures the ADS1115 at PGA +-4.096 V (125 uV per count) and 860 SPS
    (ADC_PGA 1, ADC_RATE 7). SBAS444's noise table gives one LSB rms at this range (the
    converter is quantisation limited; its peak-to-peak noise grows above 128 SPS): modelled
    as ``noise_V`` of Gaussian input noise (0.4 LSB) before the quantiser.
    """

    supply_V: float = 5.0
    bias_ohm: float = 1000.0
    pga_fs_V: float = 4.096  # ADS1115 programmable gain amplifier full scale
    noise_V: float = 50e-6  # input-referred noise, V rms


@dataclass(frozen=True)
class Sensors:
    """Ground-truth instruments."""

    camera_fps: float = 30.0  # marker tracking frame rate (sample and hold in between)
    marker_noise_mm: float = 0.15  # marker position noise, mm rms
    camera_lag_s: float = 0.0  # camera frames show the state this long before their time stamps (s)
    camera_lag_jitter_s: float = 0.033  # per-recording spread of that lag, uniform +- (s)
    contractor_length_mm: float = 50.0
    bending_marker_spacing_mm: float = 50.0  # three markers along the bending actuator (curvature)
    segment_dz_noise_mm: float = 0.2  # the 3-DoF platform's sink seen from the side while it tilts, mm rms
    imu_noise_deg: float = 0.06  # BNO055 angle noise, deg rms, before 1/16 deg quantisation
    imu_wander_deg: float = 0.4  # slow error of the BNO055's fused angles, deg rms
    imu_wander_s: float = 5.0  # its correlation time (s)


@dataclass(frozen=True)
class Geometry:
    """Kinematics of the three actuators.

    The 3-DoF segment tilts up to 26.3 / 22.6 deg (theta_x / theta_y) and sinks up to 16 mm
    (the paper's Table 1 ranges). With a rigid platform one contractor alone tilts it by
    atan(d / 45 mm) and three together sink it by d: the paper's ranges need a contractor to
    shorten more alone (22 mm) than with both neighbours on (16 mm), so the segment carries an
    axial restoring stiffness (holders, tubing) shared by the three contractors:
    ``segment_axial_kpa_per_mm`` of stress on each per mm of dz. Height and stiffness are
    chosen for the paper's three ranges.
    """

    bending_porosity: float = 84.0  # four 75 x 15 x 10 mm sections
    bending_lever_mm: float = 14.0  # section centroid to the neutral axis in the base
    bending_efficiency: float = 0.5  # share of the free section strain the base lets bend
    segment_side_mm: float = 52.0  # triangle on which the three contractors stand
    segment_height_mm: float = 160.0  # contractor height in the 3-DoF segment
    segment_porosity: float = 76.0
    segment_axial_kpa_per_mm: float = 1.5


@dataclass(frozen=True)
class Variation:
    """How one print and one recording differ from the next (relative standard deviations).

    porosense.sim.variation draws them: per print (``specimen``, per channel: three printed
    contractors differ) the contact law's scale and amplitude, the foam stiffness, the
    relaxation gains, the kinetics and R0; per recording (``seed``) the softening state at the
    start, a small change of sensitivity and R0, and the slow drift of R0 (a rate per record
    and a random walk). The paper's duplicates (one print recorded twice) differ by the
    recording's draws and the noise. The paper gives no spread; the values are a few percent,
    as far as its fits (what a WH model cannot capture) allow.
    """

    contact_strain_sd: float = 0.04
    floor_sd: float = 0.02
    modulus_sd: float = 0.03
    relax_gain_sd: float = 0.20
    kinetics_sd: float = 0.15
    r0_sd: float = 0.05
    record_gain_sd: float = 0.03  # sensitivity change between two recordings of one print
    record_r0_sd: float = 0.01  # R0 change between two recordings of one print
    record_scale_sd: float = 0.04  # contact-law scale change between two recordings of one print
    record_kinetics_sd: float = 0.15  # contact kinetics change between two recordings of one print
    conditioning_range: tuple = (0.0, 0.5)  # softening state at the start of a record
    drift_pct_per_min_sd: float = 0.3  # R0 drift rate, % of R0 per minute, one draw per record
    drift_walk_pct: float = 0.15  # random walk of R0, % rms after one minute


#: Named effects beyond the Wiener-Hammerstein chain (on by default; Physics.without switches
#: them off): what each one changes is documented where it acts.
PHYSICS_EFFECTS = (
    "rate_hysteresis",
    "relaxation",
    "log_relaxation",
    "softening",
    "repeat_variation",
    "baseline_drift",
    "sensor_noise",
    "regulator_noise",
    "segment_stiffness",
)


@dataclass(frozen=True)
class Physics:
    """All stage parameters of a plant, one frozen dataclass per stage (units on each field).

    Attributes
    ----------
    pneumatics : Pneumatics
        Regulated vacuum line, valve and chamber (time constants s, pressures kPa).
    foam : Foam
        Porous TPE under vacuum (moduli and stresses kPa, areas mm^2, creep time constants s).
    piezo : Piezo
        Piezoresistive contact network (R0 ohm, dR %, time constants s).
    electronics : Electronics
        Divider and ADS1115 (V, ohm).
    sensors : Sensors
        Ground-truth instruments (camera fps, noise mm and deg rms, lags s).
    geometry : Geometry
        Kinematics of the three actuators (mm, porosity %).
    variation : Variation
        Print-to-print and recording-to-recording spread (relative standard deviations).
    """

    pneumatics: Pneumatics = field(default_factory=Pneumatics)
    foam: Foam = field(default_factory=Foam)
    piezo: Piezo = field(default_factory=Piezo)
    electronics: Electronics = field(default_factory=Electronics)
    sensors: Sensors = field(default_factory=Sensors)
    geometry: Geometry = field(default_factory=Geometry)
    variation: Variation = field(default_factory=Variation)

    def to_dict(self) -> dict:
        """Every stage's parameters as plain dicts.

        Returns
        -------
        dict
            Stage name to its fields.
        """
        return asdict(self)

    @classmethod
    def from_dict(cls, d: dict) -> Physics:
        """Physics from :meth:`to_dict` output; missing fields keep their defaults.

        Parameters
        ----------
        d : dict
            Stage name to fields (``format``, ``version``, ``notes``, ``fit``, ``effects``,
            ``extension`` and ``calibrated_load`` keys are ignored here).

        Returns
        -------
        Physics
            The parameters.

        Raises
        ------
        InputError
            An unknown stage or parameter.
        """
        stages = {}
        for f in fields(cls):
            values = dict(d.get(f.name) or {})
            known = {g.name: g for g in fields(f.default_factory)}
            unknown = set(values) - set(known)
            if unknown:
                raise InputError(f"physics stage '{f.name}' has no parameter {sorted(unknown)}")
            base = f.default_factory()
            for k, v in values.items():
                values[k] = tuple(v) if isinstance(getattr(base, k), tuple) else type(getattr(base, k))(v)
            stages[f.name] = replace(base, **values)
        extra = {"format", "version", "notes", "fit", "effects", "extension", "calibrated_load"}
        unknown = set(d) - {f.name for f in fields(cls)} - extra
        if unknown:
            raise InputError(f"unknown physics stage(s) {sorted(unknown)}")
        return cls(**stages)

    def save(self, path, **extra) -> Path:
        """Write the parameters as JSON.

        Parameters
        ----------
        path : str or Path
            The file (its folder is made).
        **extra
            Keys stored beside the stages (notes, fit figures).

        Returns
        -------
        Path
            The file written.
        """
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(
            json.dumps({"format": "porosense.sim.physics", "version": 1, **self.to_dict(), **extra}, indent=2)
        )
        return path

    @classmethod
    def load(cls, path) -> Physics:
        """Read a parameter file written by :meth:`save` (or ``porosense calibrate``).

        Parameters
        ----------
        path : str or Path
            The JSON file.

        Returns
        -------
        Physics
            The parameters.

        Raises
        ------
        InputError
            An unreadable file, not a simulator parameter file, or an unknown stage or parameter.
        """
        try:
            d = json.loads(Path(path).read_text())
        except OSError as exc:
            raise InputError(f"cannot read simulator parameters {path}: {exc}") from None
        except ValueError as exc:
            raise InputError(f"{path} is not a simulator parameter file (not JSON: {exc})") from None
        if not isinstance(d, dict) or d.get("format") != "porosense.sim.physics":
            raise InputError(f"{path} is not a simulator parameter file (format porosense.sim.physics)")
        return cls.from_dict(d)

    def with_(self, **stages) -> Physics:
        """A copy with stage fields replaced: ``with_(piezo={'relax_s': (2.0, 9.0)})``.

        Parameters
        ----------
        **stages : dict
            Stage name to the fields replaced (units as on each stage).

        Returns
        -------
        Physics
            The copy.
        """
        updated = {name: replace(getattr(self, name), **values) for name, values in stages.items()}
        return replace(self, **updated)

    def without(self, *effects) -> Physics:
        """A copy with named effects switched off.

        Parameters
        ----------
        *effects : str
            Names from :data:`PHYSICS_EFFECTS`.

        Returns
        -------
        Physics
            The copy.

        Raises
        ------
        InputError
            An unknown effect.
        """
        unknown = set(effects) - set(PHYSICS_EFFECTS)
        if unknown:
            raise InputError(f"unknown physics effect(s) {sorted(unknown)} (known: {', '.join(PHYSICS_EFFECTS)})")
        ph = self
        pz = ph.piezo
        if "rate_hysteresis" in effects:
            ph = ph.with_(piezo={"break_s": pz.form_s})
        if "relaxation" in effects:
            ph = ph.with_(piezo={"relax_gain": tuple(0.0 for _ in pz.relax_gain)})
        if "log_relaxation" in effects:
            ph = ph.with_(piezo={"relax_log": False, "relax_gain": _additive_gains(ph.piezo)})
        if "softening" in effects:
            ph = ph.with_(piezo={"soften_fraction": 0.0})
        if "repeat_variation" in effects:
            v = ph.variation
            ph = ph.with_(
                variation={
                    "contact_strain_sd": 0.0,
                    "floor_sd": 0.0,
                    "modulus_sd": 0.0,
                    "relax_gain_sd": 0.0,
                    "kinetics_sd": 0.0,
                    "r0_sd": 0.0,
                    "record_gain_sd": 0.0,
                    "record_r0_sd": 0.0,
                    "record_scale_sd": 0.0,
                    "record_kinetics_sd": 0.0,
                    "conditioning_range": (sum(v.conditioning_range) / 2,) * 2,
                }
            )
        if "baseline_drift" in effects:
            ph = ph.with_(variation={"drift_pct_per_min_sd": 0.0, "drift_walk_pct": 0.0})
        if "sensor_noise" in effects:
            ph = ph.with_(piezo={"noise_pct": 0.0, "flicker_pct": 0.0}, electronics={"noise_V": 0.0})
        if "regulator_noise" in effects:
            ph = ph.with_(pneumatics={"regulator_noise_kpa": 0.0})
        if "segment_stiffness" in effects:
            ph = ph.with_(geometry={"segment_axial_kpa_per_mm": 0.0})
        return ph


def _additive_gains(pz: Piezo) -> tuple:
    """Relaxation gains of the additive law with about the same release overshoot (the log-domain
    overshoot exp(k |h|) - 1 at full contact, as a fraction of the full drop D)."""
    import math

    h = abs(math.log(max(1.0 - pz.floor_pct / 100.0, 1e-6)))
    return tuple(math.expm1(k * h) * 100.0 / pz.floor_pct for k in pz.relax_gain) if pz.relax_log else pz.relax_gain
