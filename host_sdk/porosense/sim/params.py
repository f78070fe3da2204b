"""Parameters of the physical chain, one dataclass per stage, with units.

Defaults are chosen so that the simulated contractors reproduce the paper's measurements
(docs/design.md, last section): strains of 15-35 % and dR of -75 to -95 % at -60 kPa for porosity
76-86 %, collapse between about -10 and -40 kPa, release overshoot above R0 that relaxes
within a 10 s cycle. Every field is documented where it is used (pneumatics, foam, piezo,
electronics, sensors modules).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, replace


@dataclass(frozen=True)
class Pneumatics:
    """Regulated vacuum line, valve and chamber of one channel."""

    tau_fill_s: float = 0.25  # chamber evacuation time constant through the open valve
    tau_vent_s: float = 0.12  # vent-to-atmosphere time constant (valve closed)
    tau_leak_s: float = 3.0  # line losing vacuum when the pump is off but the valve is open
    max_rate_kpa_s: float = 180.0  # flow limit: largest |dp/dt| the pump and vent can sustain
    min_setpoint_kpa: float = -80.0  # regulator range


@dataclass(frozen=True)
class Foam:
    """Porous conductive TPE under vacuum (Gibson-Ashby scaling in relative density 1 - phi/100)."""

    solid_modulus_kpa: float = 12000.0  # E_s of the carbon-black TPE; foam E = E_s (1 - phi/100)^2
    tension_stiffening: float = 4.0  # modulus in tension (aligned struts, rings) / E
    collapse_kpa_ref: float = 20.0  # collapse stress of the reference porosity (kPa)
    collapse_exponent: float = 1.5  # Gibson-Ashby collapse stress ~ (1 - phi/100)^1.5
    ref_porosity: float = 86.0  # porosity (%) the collapse stress refers to
    collapse_width: float = 0.35  # spread of the collapse (graded porosity), x collapse stress
    bending_scale: float = 0.40  # wall-bending strain asymptote, x densification strain
    collapse_scale: float = 0.20  # strain released by full collapse, x densification strain
    load_area_mm2: float = 346.0  # chamber cross-section the vacuum and a load act on (21 mm)
    creep_tau_s: tuple = (0.05, 0.35, 1.2)  # viscoelastic creep modes (time constants)
    creep_weight: tuple = (0.75, 0.17, 0.08)  # their share of the static strain (sum 1)


@dataclass(frozen=True)
class Piezo:
    """Piezoresistance of the carbon-black network: contacts close as pores collapse."""

    r0_ohm: float = 2200.0  # resistance of the unloaded actuator at rest
    contact_strain: float = 0.24  # collapsed share of the strain capacity at which dR = -63 % of D
    contact_exponent: float = 1.3  # shape of the contact-formation curve (> 1: slow start)
    floor_pct: float = 88.0  # largest static resistance drop D (%): densified network + electrodes
    tension_gauge_factor: float = 2.0  # dR/R per unit tensile strain (load pulling the foam)
    load_contact_coupling: float = 1.0  # contacts held open by a load: strain offset, x sigma_load / E
    contact_lag_s: float = 0.5  # pore-contact strain lags the marker strain (lead-lag pole)
    contact_lead_s: float = 0.12  # ... lead-lag zero (instantaneous share = lead / lag)
    relax_s: float = 3.0  # resistance relaxation time constant (network reformation)
    relax_gain: float = 0.13  # relaxation overshoot as a fraction of the change in dR;
    # D (1 + gain) < 100 keeps R > 0 during a loading undershoot
    relax_r_scaling: float = 0.0  # 0: relaxation additive in dR (a linear block: the dR -> strain
    # map is exactly Wiener-Hammerstein); 1: proportional to R/R0
    noise_pct: float = 0.04  # contact/flicker noise, dR % rms


@dataclass(frozen=True)
class Electronics:
    """Divider (5 V -> bias -> node -> sensor -> GND) and ADS1115."""

    supply_V: float = 5.0
    bias_ohm: float = 1000.0
    pga_fs_V: float = 4.096  # ADS1115 programmable gain amplifier full scale
    noise_V: float = 60e-6  # input-referred noise, V rms


@dataclass(frozen=True)
class Sensors:
    """Ground-truth instruments."""

    camera_fps: float = 30.0  # marker tracking frame rate (sample and hold in between)
    marker_noise_mm: float = 0.08  # marker position noise, mm rms
    contractor_length_mm: float = 50.0
    imu_noise_deg: float = 0.06  # BNO055 angle noise, deg rms, before 1/16 deg quantisation


@dataclass(frozen=True)
class Geometry:
    """Kinematics of the three actuators."""

    bending_porosity: float = 84.0  # four 75 x 15 x 10 mm sections
    bending_lever_mm: float = 14.0  # section centroid to the neutral axis in the base
    bending_efficiency: float = 0.5  # share of the free section strain the base lets bend
    segment_side_mm: float = 52.0  # triangle on which the three contractors stand
    segment_height_mm: float = 95.0  # contractor height in the 3-DoF segment (dz up to ~16 mm)
    segment_porosity: float = 76.0


@dataclass(frozen=True)
class Physics:
    """All stage parameters of a plant."""

    pneumatics: Pneumatics = field(default_factory=Pneumatics)
    foam: Foam = field(default_factory=Foam)
    piezo: Piezo = field(default_factory=Piezo)
    electronics: Electronics = field(default_factory=Electronics)
    sensors: Sensors = field(default_factory=Sensors)
    geometry: Geometry = field(default_factory=Geometry)

    def to_dict(self) -> dict:
        return asdict(self)

    def with_(self, **stages) -> Physics:
        """A copy with stage fields replaced: ``with_(piezo={'relax_s': 2.0})``."""
        updated = {name: replace(getattr(self, name), **values) for name, values in stages.items()}
        return replace(self, **updated)
