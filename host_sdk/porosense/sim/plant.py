"""The plant: one actuator's whole physical chain, stepped or run vectorised.

Per channel and sample (first-order stages use ``a = exp(-dt/tau)``,
``y[k] = a y[k-1] + (1 - a) u[k]``):

1. pneumatics: chamber pressure ``p`` (kPa) from setpoint, pump and valve;
2. foam: stress ``sigma = -p - sigma_load`` (kPa) -> static strain (collapse curve) -> creep
   modes -> strain ``eps`` (fraction of the unloaded length);
3. piezo: contact strain ``eps_c = r eps + (1 - r) LP_lag(eps) - c sigma_load / E`` (lead-lag;
   a load's tension in the cell walls holds contacts open) -> contact dR
   (static, pore collapse) -> network relaxation ``dR = g + k (g - LP_relax(g))``;
4. electronics: ``R = R0 (1 + dR/100)``, divider voltage with noise;
5. kinematics: strain, curvature or segment pose; BNO055 Euler angles.

:meth:`Plant.step` advances one sample (the emulator and the simboard call it in lockstep);
:meth:`Plant.run` computes a whole actuation series with the same equations, vectorised
(``scipy.signal.lfilter`` for the linear stages). Without noise the two agree to rounding;
with noise they draw from different random streams.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from porosense.errors import InputError
from porosense.sim import kinematics, pneumatics
from porosense.sim.effects import resolve_effects
from porosense.sim.electronics import divider_voltage
from porosense.sim.foam import FoamCurve, load_stress_kpa
from porosense.sim.params import Physics
from porosense.sim.piezo import contact_dr, contact_dr_scalar

ACTUATORS = ("contractor", "bending", "3dof")
OUTPUTS = {"contractor": ("strain_0",), "bending": ("curvature",), "3dof": ("theta_x", "theta_y", "dz")}
OUTPUT_UNITS = {"strain_0": "%", "curvature": "1/m", "theta_x": "deg", "theta_y": "deg", "dz": "mm"}
POROSITY_RANGE = (60.0, 90.0)
LOAD_RANGE_G = (0.0, 500.0)
IMU_LSB_DEG = 1.0 / 16.0


@dataclass
class PlantReading:
    """What the board's sensors see after one step, plus the ground truth.

    ``voltage_V``: (3,) ADC input voltages (0 for unconnected channels); ``euler_deg``: (3,)
    BNO055 heading, roll, pitch (deg, 1/16 deg steps); ``truth``: recording-named values
    (``p_0`` kPa, ``R_0`` ohm, ``dR_0`` %, ``strain_0`` %, ``curvature`` 1/m, ``theta_x`` deg, ...).
    """

    voltage_V: np.ndarray
    euler_deg: np.ndarray
    truth: dict = field(default_factory=dict)


def default_porosity(actuator: str, physics: Physics = Physics()) -> float:
    """Porosity (%) of an actuator when none is given."""
    return {
        "contractor": 82.0,
        "bending": physics.geometry.bending_porosity,
        "3dof": physics.geometry.segment_porosity,
    }[actuator]


def check_actuator(actuator: str) -> str:
    if actuator not in ACTUATORS:
        raise InputError(f"unknown actuator '{actuator}' (known: {', '.join(ACTUATORS)})")
    return actuator


class _NoiseBank:
    """Pre-drawn standard normals and uniforms, handed out one at a time (cheap per step)."""

    def __init__(self, rng: np.random.Generator, block: int = 4096):
        self.rng, self.block = rng, block
        self._n, self._u, self.i, self.j = [], [], 0, 0

    def normal(self) -> float:
        if self.i >= len(self._n):
            self._n, self.i = self.rng.standard_normal(self.block).tolist(), 0
        self.i += 1
        return self._n[self.i - 1]

    def uniform(self) -> float:
        if self.j >= len(self._u):
            self._u, self.j = self.rng.random(self.block).tolist(), 0
        self.j += 1
        return self._u[self.j - 1]


class Plant:
    """One actuator (see module docstring); build it with :func:`make_plant`."""

    def __init__(
        self,
        actuator: str,
        porosity=None,
        load_g: float = 0.0,
        seed: int = 0,
        effects=None,
        physics: Physics | None = None,
        noise: bool = True,
    ):
        self.actuator = check_actuator(actuator)
        self.physics = physics or Physics()
        self.porosity = float(default_porosity(actuator, self.physics) if porosity is None else porosity)
        if not POROSITY_RANGE[0] <= self.porosity <= POROSITY_RANGE[1]:
            raise InputError(f"porosity {self.porosity} % is outside {POROSITY_RANGE[0]:g}-{POROSITY_RANGE[1]:g} %")
        self.load_g = float(load_g)
        if not LOAD_RANGE_G[0] <= self.load_g <= LOAD_RANGE_G[1]:
            raise InputError(f"load {self.load_g} g is outside {LOAD_RANGE_G[0]:g}-{LOAD_RANGE_G[1]:g} g")
        self.seed = int(seed)
        self.effects = resolve_effects(effects)
        self.noise = bool(noise)
        self.n_channels = 3 if actuator == "3dof" else 1
        self.outputs = OUTPUTS[actuator]
        self.curve = FoamCurve.of(self.porosity, self.physics.foam)
        pz = self.physics.piezo
        self._lead_share = pz.contact_lead_s / pz.contact_lag_s
        # strain by which a load's tension in the cell walls holds contacts open, per kPa
        self._load_contact = pz.load_contact_coupling / self.curve.modulus_kpa
        self._sigma_load0 = float(load_stress_kpa(self.load_g, self.physics.foam))
        self._pose = kinematics.SegmentPose(self.physics.geometry)
        self._alpha_cache: dict = {}
        self.reset()

    # --- shared pieces --------------------------------------------------------------------
    def load_at(self, t):
        """Load (g) at plant time ``t`` (s): constant unless ``load_dependence`` is on."""
        eff = self.effects.get("load_dependence")
        if eff is None:
            return self.load_g + 0.0 * np.asarray(t, dtype=float)
        frac = np.clip((np.asarray(t, dtype=float) - eff["start_s"]) / max(eff["ramp_s"], 1e-9), 0.0, 1.0)
        return self.load_g + eff["delta_g"] * frac

    def _alphas(self, dt: float) -> dict:
        a = self._alpha_cache.get(dt)
        if a is None:
            f, pz = self.physics.foam, self.physics.piezo
            slow = self.effects.get("slow_relaxation", {"tau_s": 1.0})
            a = {
                "creep": [math.exp(-dt / tau) for tau in f.creep_tau_s],
                "lag": math.exp(-dt / pz.contact_lag_s),
                "relax": math.exp(-dt / pz.relax_s),
                "slow": math.exp(-dt / slow["tau_s"]),
            }
            if len(self._alpha_cache) > 64:  # callers with a jittering dt: keep the cache small
                self._alpha_cache.clear()
            self._alpha_cache[dt] = a
        return a

    def _rest(self, load_g: float) -> tuple[float, float]:
        """Strain (fraction) and contact dR (%) at rest under ``load_g``."""
        sigma = float(load_stress_kpa(load_g, self.physics.foam))
        eps = self.curve.strain_scalar(-sigma)
        eps_c = eps - self._load_contact * sigma
        return eps, contact_dr_scalar(eps_c, self.physics.piezo, self.curve.capacity)

    def reset(self) -> None:
        """Back to rest at t = 0 with the initial load and a fresh random stream."""
        self.t = 0.0
        self._noise = _NoiseBank(np.random.default_rng(self.seed))
        eps, g = self._rest(self.load_g)
        self._eps_rest = eps
        n = self.n_channels
        self._p = [0.0] * n
        self._creep = [[eps] * len(self.physics.foam.creep_tau_s) for _ in range(n)]
        self._lag = [eps] * n
        self._relax = [g] * n
        self._slow = [g] * n
        self._delay: list = []
        self._last_v = [None] * n

    # --- one sample -----------------------------------------------------------------------
    def step(self, dt_s: float, setpoint_kpa, pump, valve) -> PlantReading:
        """Advance ``dt_s`` seconds with the given actuation (arrays of 3) and read the sensors."""
        dt = float(dt_s)
        if not dt > 0.0:
            raise InputError(f"time step must be positive, got {dt_s}")
        self.t += dt
        t = self.t
        ph, eff, nb, noisy = self.physics, self.effects, self._noise, self.noise
        f, pz, el = ph.foam, ph.piezo, ph.electronics
        al = self._alphas(dt)
        sigma_load = float(load_stress_kpa(self.load_at(t), f)) if "load_dependence" in eff else self._sigma_load0
        n = self.n_channels
        eps, eps_c = [0.0] * n, [0.0] * n
        r = self._lead_share
        a_lag = al["lag"]
        for c in range(n):
            p = pneumatics.step_pressure(
                self._p[c], dt, float(setpoint_kpa[c]), bool(pump[c]), bool(valve[c]), ph.pneumatics
            )
            self._p[c] = p
            es = self.curve.strain_scalar(-p - sigma_load)
            modes = self._creep[c]
            e = 0.0
            for i, (a, w) in enumerate(zip(al["creep"], f.creep_weight)):
                modes[i] = a * modes[i] + (1.0 - a) * es
                e += w * modes[i]
            self._lag[c] = a_lag * self._lag[c] + (1.0 - a_lag) * e
            eps[c] = e
            eps_c[c] = r * e + (1.0 - r) * self._lag[c] - self._load_contact * sigma_load
        if "cross_coupling" in eff and n > 1:
            k = eff["cross_coupling"]["gain"]
            rel = [e - self._eps_rest for e in eps]
            total = sum(rel)
            eps_c = [ec + k * (total - rc) for ec, rc in zip(eps_c, rel)]

        a_r, a_s = al["relax"], al["slow"]
        volts = [0.0, 0.0, 0.0]
        truth = {}
        drift = 1.0 + eff["drift"]["rate_pct_per_min"] / 100.0 * t / 60.0 if "drift" in eff else 1.0
        for c in range(n):
            g = contact_dr_scalar(eps_c[c], pz, self.curve.capacity)
            self._relax[c] = a_r * self._relax[c] + (1.0 - a_r) * g
            dr = g + pz.relax_gain * (g - self._relax[c]) * (1.0 + pz.relax_r_scaling * g / 100.0)
            if "slow_relaxation" in eff:
                self._slow[c] = a_s * self._slow[c] + (1.0 - a_s) * g
                dr += eff["slow_relaxation"]["gain"] * (g - self._slow[c]) * (1.0 + g / 100.0)
            r_true = pz.r0_ohm * (1.0 + dr / 100.0)
            truth[f"p_{c}"], truth[f"R_{c}"], truth[f"dR_{c}"] = self._p[c], r_true, dr
            truth[f"strain_{c}"] = 100.0 * eps[c]
            dr_seen = dr + (pz.noise_pct * nb.normal() if noisy else 0.0)
            if "periodic_disturbance" in eff:
                pd = eff["periodic_disturbance"]
                dr_seen += pd["amplitude_pct"] * math.sin(
                    2.0 * math.pi * pd["freq_hz"] * t + math.radians(pd["phase_deg"])
                )
            if "outliers" in eff and nb.uniform() < eff["outliers"]["glitch_prob"]:
                dr_seen += eff["outliers"]["glitch_pct"] * (1.0 if nb.uniform() < 0.5 else -1.0)
            volts[c] = max(pz.r0_ohm * drift * (1.0 + dr_seen / 100.0), 1.0)  # R for now
        if "time_delay" in eff:
            self._delay.append((t, volts[:]))
            while len(self._delay) > 1 and self._delay[1][0] <= t - eff["time_delay"]["delay_s"] + 1e-12:
                self._delay.pop(0)
            volts = self._delay[0][1][:]
        for c in range(n):
            r_ohm = volts[c]
            v = el.supply_V * r_ohm / (r_ohm + el.bias_ohm) + (el.noise_V * nb.normal() if noisy else 0.0)
            if "saturation" in eff:
                v = min(max(v, eff["saturation"]["low_V"]), eff["saturation"]["high_V"])
            if "outliers" in eff and self._last_v[c] is not None and nb.uniform() < eff["outliers"]["drop_prob"]:
                v = self._last_v[c]  # a dropped conversion: the previous value is read again
            self._last_v[c] = v
            volts[c] = v

        euler = [0.0, 0.0, 0.0]
        if self.actuator == "contractor":
            pass
        elif self.actuator == "bending":
            truth["curvature"] = float(kinematics.bending_curvature(eps[0], ph.geometry))
        else:
            tx, ty, dz = self._pose(eps[0], eps[1], eps[2])
            truth["theta_x"], truth["theta_y"], truth["dz"] = tx, ty, dz
            euler = [0.0, tx, ty]
        if noisy:
            s = ph.sensors.imu_noise_deg
            euler = [e + s * nb.normal() for e in euler]
        euler = [round(e * 16.0) / 16.0 for e in euler]
        truth["load_g"] = float(self.load_at(t)) if "load_dependence" in eff else self.load_g
        return PlantReading(np.array(volts), np.array(euler), truth)

    # --- a whole series -------------------------------------------------------------------
    def run(self, dt_s: float, setpoint_kpa, pump, valve) -> dict:
        """Simulate an actuation series from rest (the plant's own state is not touched).

        ``setpoint_kpa``, ``pump``, ``valve``: (N, 3) arrays, sample k applied over
        ``(k dt, (k+1) dt]``. Returns arrays: ``voltage_V`` (N, 3), ``euler_deg`` (N, 3),
        ``dropped`` (N,) bool, and the truth columns (``p_0``, ``R_0``, ``dR_0``,
        ``strain_0``, outputs, ``load_g``) as in :meth:`step`.
        """
        dt = float(dt_s)
        setpoint_kpa = np.atleast_2d(np.asarray(setpoint_kpa, dtype=float))
        pump = np.atleast_2d(np.asarray(pump, dtype=bool))
        valve = np.atleast_2d(np.asarray(valve, dtype=bool))
        N = setpoint_kpa.shape[0]
        t = dt * np.arange(1, N + 1)
        ph, eff, n = self.physics, self.effects, self.n_channels
        f, pz, el = ph.foam, ph.piezo, ph.electronics
        rng = np.random.default_rng(self.seed)
        noisy = self.noise
        al = self._alphas(dt)
        load = self.load_at(t)
        sigma_load = load_stress_kpa(load, f)
        eps_rest, g_rest = self._rest(self.load_g)
        r = self._lead_share

        def first_order(u, a, y0):
            return lfilter([1.0 - a], [1.0, -a], u, zi=[a * y0])[0]

        out: dict = {}
        eps = np.zeros((N, n))
        eps_c = np.zeros((N, n))
        for c in range(n):
            p = pneumatics.run_pressure(dt, setpoint_kpa[:, c], pump[:, c], valve[:, c], ph.pneumatics)
            out[f"p_{c}"] = p
            es = self.curve.strain(-p - sigma_load)
            e = sum(w * first_order(es, a, eps_rest) for a, w in zip(al["creep"], f.creep_weight))
            eps[:, c] = e
            eps_c[:, c] = r * e + (1.0 - r) * first_order(e, al["lag"], eps_rest) - self._load_contact * sigma_load
        if "cross_coupling" in eff and n > 1:
            rel = eps - eps_rest
            eps_c = eps_c + eff["cross_coupling"]["gain"] * (rel.sum(axis=1, keepdims=True) - rel)

        drift = 1.0 + eff["drift"]["rate_pct_per_min"] / 100.0 * t / 60.0 if "drift" in eff else 1.0
        r_seen = np.zeros((N, n))
        for c in range(n):
            g = contact_dr(eps_c[:, c], pz, self.curve.capacity)
            dr = g + pz.relax_gain * (g - first_order(g, al["relax"], g_rest)) * (1.0 + pz.relax_r_scaling * g / 100.0)
            if "slow_relaxation" in eff:
                dr = dr + eff["slow_relaxation"]["gain"] * (g - first_order(g, al["slow"], g_rest)) * (1.0 + g / 100.0)
            out[f"R_{c}"] = pz.r0_ohm * (1.0 + dr / 100.0)
            out[f"dR_{c}"] = dr
            out[f"strain_{c}"] = 100.0 * eps[:, c]
            dr_seen = dr + (pz.noise_pct * rng.standard_normal(N) if noisy else 0.0)
            if "periodic_disturbance" in eff:
                pd = eff["periodic_disturbance"]
                dr_seen = dr_seen + pd["amplitude_pct"] * np.sin(
                    2.0 * np.pi * pd["freq_hz"] * t + np.radians(pd["phase_deg"])
                )
            if "outliers" in eff:
                o = eff["outliers"]
                hit = rng.random(N) < o["glitch_prob"]
                dr_seen = dr_seen + hit * o["glitch_pct"] * np.where(rng.random(N) < 0.5, 1.0, -1.0)
            r_seen[:, c] = np.maximum(pz.r0_ohm * drift * (1.0 + dr_seen / 100.0), 1.0)
        if "time_delay" in eff:
            lag = int(round(eff["time_delay"]["delay_s"] / dt))
            if lag > 0:
                r_seen = np.vstack([np.repeat(r_seen[:1], min(lag, N), axis=0), r_seen[:-lag]])[:N]
        volts = np.zeros((N, 3))
        v = divider_voltage(r_seen, el)
        if noisy:
            v = v + el.noise_V * rng.standard_normal(v.shape)
        if "saturation" in eff:
            v = np.clip(v, eff["saturation"]["low_V"], eff["saturation"]["high_V"])
        volts[:, :n] = v
        out["voltage_V"] = volts
        dropped = np.zeros(N, dtype=bool)
        if "outliers" in eff:
            dropped = rng.random(N) < eff["outliers"]["drop_prob"]
            dropped[0] = False
        out["dropped"] = dropped

        euler = np.zeros((N, 3))
        if self.actuator == "bending":
            out["curvature"] = kinematics.bending_curvature(eps[:, 0], ph.geometry)
        elif self.actuator == "3dof":
            tx, ty, dz = kinematics.segment_pose(eps, ph.geometry)
            out["theta_x"], out["theta_y"], out["dz"] = tx, ty, dz
            euler[:, 1], euler[:, 2] = tx, ty
        if noisy:
            euler = euler + ph.sensors.imu_noise_deg * rng.standard_normal(euler.shape)
        out["euler_deg"] = np.round(euler / IMU_LSB_DEG) * IMU_LSB_DEG
        out["load_g"] = np.asarray(load, dtype=float) * np.ones(N)
        out["t_plant"] = t
        return out


def make_plant(
    actuator: str,
    porosity=None,
    load_g: float = 0.0,
    seed: int = 0,
    effects=None,
    physics: Physics | None = None,
    noise: bool = True,
) -> Plant:
    """A plant of ``actuator`` ('contractor', 'bending', '3dof') at rest.

    ``porosity`` in % (60-90; default 82 for the contractor, 84 bending, 76 3-DoF), ``load_g``
    hanging load in g (0-500), ``seed`` of the noise, ``effects`` (see porosense.sim.effects),
    ``physics`` to override stage parameters, ``noise=False`` for a noiseless plant.
    """
    return Plant(actuator, porosity, load_g, seed, effects, physics, noise)
