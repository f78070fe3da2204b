"""The plant: one actuator's whole physical chain, stepped or run vectorised.

Per channel and sample (first-order stages use ``a = exp(-dt/tau)``,
``y[k] = a y[k-1] + (1 - a) u[k]``):

1. pneumatics: chamber pressure ``p`` (kPa) from setpoint, pump and valve, plus the
   regulator's wander while the pump drives (``regulator_noise``);
2. foam: stress ``sigma = -p - sigma_load`` (kPa; on the 3-DoF segment also the axial
   restoring stress of the platform, ``segment_stiffness``) -> static strain (collapse curve)
   -> creep modes -> strain ``eps`` (fraction of the unloaded length);
3. piezo: contact strain ``e = eps - c sigma_load / E`` (a load's tension in the cell walls
   holds contacts open) -> the contact network (porosense.sim.material: rate-dependent
   contact kinetics, softening, static pore-collapse curve, two-mode relaxation) -> dR;
4. electronics: ``R = R0 (1 + drift) (1 + dR/100)`` with contact noise, divider voltage
   with the ADS1115's noise;
5. kinematics: strain, curvature or segment pose; BNO055 Euler angles.

Each channel is one printed contractor with parameters of its own (porosense.sim.variation,
drawn from the seed). :meth:`Plant.step` advances one sample (the emulator and the simboard
call it in lockstep); :meth:`Plant.run` computes a whole actuation series with the same
equations, vectorised where the stage is linear. Without noise the two agree to rounding;
with noise they draw from different random streams.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.signal import lfilter

from porosense.errors import InputError
from porosense.sim import kinematics, pneumatics
from porosense.sim.effects import measured_load, resolve_effects
from porosense.sim.electronics import divider_voltage
from porosense.sim.foam import FoamCurve, load_stress_kpa
from porosense.sim.material import ContactNetwork
from porosense.sim.noise import NormalBank, ou_coefficients, ou_series, walk_series
from porosense.sim.params import Physics
from porosense.sim.variation import draw_channels

ACTUATORS = ("contractor", "bending", "3dof")
OUTPUTS = {"contractor": ("strain_0",), "bending": ("curvature",), "3dof": ("theta_x", "theta_y", "dz")}
OUTPUT_UNITS = {"strain_0": "%", "curvature": "1/m", "theta_x": "deg", "theta_y": "deg", "dz": "mm"}
POROSITY_RANGE = (60.0, 90.0)
LOAD_RANGE_G = (0.0, 500.0)
IMU_LSB_DEG = 1.0 / 16.0
COUPLING_ITERATIONS = 4  # Newton steps of the segment's axial coupling (converged to rounding)
REGULATOR_FULL_KPA = 10.0  # the regulator's wander reaches its full size beyond this vacuum


@dataclass
class PlantReading:
    """What the board's sensors see after one step, plus the ground truth.

    Attributes
    ----------
    voltage_V : ndarray, shape (3,)
        ADC input voltages, V (0 for unconnected channels).
    euler_deg : ndarray, shape (3,)
        BNO055 heading, roll, pitch, deg, in 1/16 deg steps.
    truth : dict
        Recording-named values: ``p_0`` kPa, ``R_0`` ohm, ``dR_0`` %, ``strain_0`` %,
        ``curvature`` 1/m, ``theta_x`` deg, ...
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


class Plant:
    """One actuator's physical chain (see the module notes); build it with :func:`make_plant`.

    Parameters
    ----------
    actuator : str
        ``"contractor"``, ``"bending"`` or ``"3dof"``.
    porosity : float or None
        Porosity, % (60-90; None: 82 for the contractor, 84 bending, 76 3-DoF).
    load_g : float
        Hanging load, g (0-500).
    seed : int
        Seed of the recording: its noise and its share of the variation.
    effects : list of str, dict or None
        Named extra effects (porosense.sim.effects), off by default.
    physics : Physics or None
        Stage parameters (None: the defaults, porosense.sim.params).
    noise : bool
        False for noiseless sensors (the realisation drawn from the seeds stays).
    specimen : int
        The printed actuator (porosense.sim.variation): duplicates share one specimen.

    Raises
    ------
    InputError
        An unknown actuator or effect, or a porosity or load outside its range.
    """

    def __init__(
        self,
        actuator: str,
        porosity=None,
        load_g: float = 0.0,
        seed: int = 0,
        effects=None,
        physics: Physics | None = None,
        noise: bool = True,
        specimen: int = 0,
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
        self.specimen = int(specimen)
        self.effects = resolve_effects(effects)
        column = measured_load(self.effects)
        if column is not None:
            raise InputError(
                f"load_dependence here takes the load from a recording's column '{column[0]}' (g): it runs on a "
                "recording (porosense simulate --params FILE --replay REC), not on a schedule"
            )
        self.noise = bool(noise)
        self.n_channels = 3 if actuator == "3dof" else 1
        self.outputs = OUTPUTS[actuator]
        f = self.physics.foam
        self.draws = draw_channels(self.physics, self.specimen, self.seed, self.n_channels)
        self.curves = [
            FoamCurve.of(
                self.porosity,
                replace(
                    f,
                    solid_modulus_kpa=f.solid_modulus_kpa * d.modulus_factor,
                    collapse_kpa_ref=f.collapse_kpa_ref * d.modulus_factor,
                ),
            )
            for d in self.draws
        ]
        self.curve = FoamCurve.of(self.porosity, f)  # the nominal print (steady state, planning)
        # strain by which a load's tension in the cell walls holds contacts open, per kPa
        self._load_contact = [d.piezo.load_contact_coupling / c.modulus_kpa for d, c in zip(self.draws, self.curves)]
        self._sigma_load0 = float(load_stress_kpa(self.load_g, f))
        g = self.physics.geometry
        self._axial = g.segment_axial_kpa_per_mm * g.segment_height_mm / 3.0 if self.n_channels == 3 else 0.0
        self._pose = kinematics.SegmentPose(g)
        self._alpha_cache: dict = {}
        self.reset()

    # --- shared pieces --------------------------------------------------------------------
    def load_at(self, t):
        """The load at plant time ``t``: constant unless ``load_dependence`` is on.

        Parameters
        ----------
        t : float or array_like
            Plant time, s.

        Returns
        -------
        ndarray
            Load, g.
        """
        eff = self.effects.get("load_dependence")
        if eff is None:
            return self.load_g + 0.0 * np.asarray(t, dtype=float)
        frac = np.clip((np.asarray(t, dtype=float) - eff["start_s"]) / max(eff["ramp_s"], 1e-9), 0.0, 1.0)
        return self.load_g + eff["delta_g"] * frac

    def _alphas(self, dt: float) -> dict:
        a = self._alpha_cache.get(dt)
        if a is None:
            f, pz, pn = self.physics.foam, self.physics.piezo, self.physics.pneumatics
            slow = self.effects.get("slow_relaxation", {"tau_s": 1.0})
            a = {
                "creep": [math.exp(-dt / tau) for tau in f.creep_tau_s],
                "slow": math.exp(-dt / slow["tau_s"]),
                "regulator": ou_coefficients(dt, pn.regulator_noise_kpa, pn.regulator_noise_s),
                "flicker": ou_coefficients(dt, pz.flicker_pct, pz.flicker_s),
                "walk": self.physics.variation.drift_walk_pct * math.sqrt(dt / 60.0),
                "imu": ou_coefficients(dt, self.physics.sensors.imu_wander_deg, self.physics.sensors.imu_wander_s),
            }
            if len(self._alpha_cache) > 64:  # callers with a jittering dt: keep the cache small
                self._alpha_cache.clear()
            self._alpha_cache[dt] = a
        return a

    def _static_strains(self, stress) -> list:
        """Static strain (fraction) of each channel at compressive stresses ``stress`` (kPa,
        one per channel, scalars or arrays), with the segment's axial coupling solved: the
        platform's restoring stress ``k dz`` with ``dz = H sum(eps) / 3`` enters each channel,
        so the strain sum S solves ``S = sum_i F_i(sigma_i - a S)`` (Newton, monotone)."""
        curves = self.curves
        if self._axial == 0.0:
            return [c.strain(s) for c, s in zip(curves, stress)]
        a = self._axial
        total = sum(c.strain(s) for c, s in zip(curves, stress)) * 0.5
        for _ in range(COUPLING_ITERATIONS):
            shifted = [s - a * total for s in stress]
            resid = sum(c.strain(s) for c, s in zip(curves, shifted)) - total
            total = total + resid / (1.0 + a * sum(c.slope(s) for c, s in zip(curves, shifted)))
        return [c.strain(s - a * total) for c, s in zip(curves, stress)]

    def static_strains_scalar(self, stress: list) -> list:
        """Static strain of each channel at given stresses, the segment's axial coupling solved (one
        float per channel, for stepping).

        Parameters
        ----------
        stress : list of float
            Compressive stress per channel, kPa.

        Returns
        -------
        list of float
            Strain per channel, fraction of the unloaded length.
        """
        curves = self.curves
        if self._axial == 0.0:
            return [c.strain_scalar(s) for c, s in zip(curves, stress)]
        a = self._axial
        total = sum(c.strain_scalar(s) for c, s in zip(curves, stress)) * 0.5
        for _ in range(COUPLING_ITERATIONS):
            shifted = [s - a * total for s in stress]
            resid = sum(c.strain_scalar(s) for c, s in zip(curves, shifted)) - total
            total = total + resid / (1.0 + a * sum(c.slope_scalar(s) for c, s in zip(curves, shifted)))
        return [c.strain_scalar(s - a * total) for c, s in zip(curves, stress)]

    def rest_state(self, load_g: float) -> tuple[list, list]:
        """Strain and contact strain of each channel at rest under a load.

        Parameters
        ----------
        load_g : float
            Hanging load, g.

        Returns
        -------
        strain : list of float
            Per channel, fraction of the unloaded length.
        contact_strain : list of float
            Per channel, fraction (the strain less what the load's tension holds open).
        """
        sigma = float(load_stress_kpa(load_g, self.physics.foam))
        eps = self.static_strains_scalar([-sigma] * self.n_channels)
        return eps, [e - lc * sigma for e, lc in zip(eps, self._load_contact)]

    def reset(self) -> None:
        """Back to rest at t = 0 with the initial load and a fresh random stream."""
        self.t = 0.0
        self._noise = NormalBank(np.random.default_rng(self.seed))
        eps, e_c = self.rest_state(self.load_g)
        self._eps_rest = eps
        n = self.n_channels
        self._p = [0.0] * n
        self._creep = [[e] * len(self.physics.foam.creep_tau_s) for e in eps]
        self._net = []
        for d, c, e in zip(self.draws, self.curves, e_c):
            net = ContactNetwork(d.piezo, c.capacity * d.piezo.contact_strain, d.conditioning)
            net.reset(e)
            self._net.append(net)
        self._slow = [net.g for net in self._net]
        pn, pz = self.physics.pneumatics, self.physics.piezo
        nb = self._noise
        self._reg = [pn.regulator_noise_kpa * nb.normal() if self.noise else 0.0 for _ in range(n)]
        self._flicker = [pz.flicker_pct * nb.normal() if self.noise else 0.0 for _ in range(n)]
        self._walk = [0.0] * n
        w = self.physics.sensors.imu_wander_deg
        self._imu = [w * nb.normal() if self.noise else 0.0 for _ in range(3)]
        self._delay: list = []
        self._last_v = [None] * n

    # --- one sample -----------------------------------------------------------------------
    def step(self, dt_s: float, setpoint_kpa, pump, valve) -> PlantReading:
        """Advance one time step with the given actuation and read the sensors.

        Parameters
        ----------
        dt_s : float
            Time step, s (> 0).
        setpoint_kpa : sequence of float
            Regulator setpoint per channel (3), kPa (<= 0).
        pump, valve : sequence of bool
            Pump and valve state per channel (3).

        Returns
        -------
        PlantReading
            ADC voltages (V), BNO055 angles (deg) and the ground truth.

        Raises
        ------
        InputError
            A time step that is not positive.
        """
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
        a_reg, b_reg = al["regulator"]
        stress = [0.0] * n
        for c in range(n):
            p = pneumatics.step_pressure(
                self._p[c], dt, float(setpoint_kpa[c]), bool(pump[c]), bool(valve[c]), ph.pneumatics
            )
            self._p[c] = p
            if noisy:
                self._reg[c] = a_reg * self._reg[c] + b_reg * nb.normal()
            stress[c] = -(p + self._reg[c] * min(-p / REGULATOR_FULL_KPA, 1.0)) - sigma_load if p < 0 else -sigma_load
        es = self.static_strains_scalar(stress)
        eps, eps_c = [0.0] * n, [0.0] * n
        for c in range(n):
            modes = self._creep[c]
            e = 0.0
            for i, (a, w) in enumerate(zip(al["creep"], f.creep_weight)):
                modes[i] = a * modes[i] + (1.0 - a) * es[c]
                e += w * modes[i]
            eps[c] = e
            eps_c[c] = e - self._load_contact[c] * sigma_load
        if "cross_coupling" in eff and n > 1:
            k = eff["cross_coupling"]["gain"]
            rel = [e - er for e, er in zip(eps, self._eps_rest)]
            total = sum(rel)
            eps_c = [ec + k * (total - rc) for ec, rc in zip(eps_c, rel)]

        a_s = al["slow"]
        a_fl, b_fl = al["flicker"]
        volts = [0.0, 0.0, 0.0]
        truth = {}
        drift = 1.0 + eff["drift"]["rate_pct_per_min"] / 100.0 * t / 60.0 if "drift" in eff else 1.0
        for c in range(n):
            d = self.draws[c]
            dr = self._net[c].step(eps_c[c], dt)
            if "slow_relaxation" in eff:
                g = self._net[c].g
                self._slow[c] = a_s * self._slow[c] + (1.0 - a_s) * g
                dr += eff["slow_relaxation"]["gain"] * (g - self._slow[c]) * (1.0 + g / 100.0)
            if noisy:
                self._walk[c] += al["walk"] * nb.normal()
            base = 1.0 + (d.drift_pct_per_min * t / 60.0 + self._walk[c]) / 100.0
            r_true = d.r0_ohm * base * (1.0 + dr / 100.0)
            truth[f"p_{c}"], truth[f"R_{c}"], truth[f"dR_{c}"] = self._p[c], r_true, dr
            truth[f"strain_{c}"] = 100.0 * eps[c]
            dr_seen = dr
            if noisy:
                self._flicker[c] = a_fl * self._flicker[c] + b_fl * nb.normal()
                dr_seen += pz.noise_pct * nb.normal() + self._flicker[c]
            if "periodic_disturbance" in eff:
                pd = eff["periodic_disturbance"]
                dr_seen += pd["amplitude_pct"] * math.sin(
                    2.0 * math.pi * pd["freq_hz"] * t + math.radians(pd["phase_deg"])
                )
            if "outliers" in eff and nb.uniform() < eff["outliers"]["glitch_prob"]:
                dr_seen += eff["outliers"]["glitch_pct"] * (1.0 if nb.uniform() < 0.5 else -1.0)
            volts[c] = max(d.r0_ohm * base * drift * (1.0 + dr_seen / 100.0), 1.0)  # R for now
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
            a_w, b_w = al["imu"]
            self._imu = [a_w * w + b_w * nb.normal() for w in self._imu]
            euler = [e + w + s * nb.normal() for e, w in zip(euler, self._imu)]
        euler = [round(e * 16.0) / 16.0 for e in euler]
        truth["load_g"] = float(self.load_at(t)) if "load_dependence" in eff else self.load_g
        return PlantReading(np.array(volts), np.array(euler), truth)

    # --- a whole series -------------------------------------------------------------------
    def run(self, dt_s: float, setpoint_kpa, pump, valve, load_g=None) -> dict:
        """Simulate an actuation series from rest (the plant's own state is not touched).

        Parameters
        ----------
        dt_s : float
            Sample period, s; sample k is applied over (k dt, (k+1) dt].
        setpoint_kpa : array_like, shape (N, 3)
            Regulator setpoints, kPa (<= 0).
        pump, valve : array_like of bool, shape (N, 3)
            Pump and valve states.
        load_g : array_like, shape (N,), optional
            The hanging load during the series, g, in place of the plant's own (its constant
            load, or ``load_dependence``'s ramp); the series starts at rest under its first value.

        Returns
        -------
        dict of str to ndarray
            ``voltage_V`` (N, 3) V, ``euler_deg`` (N, 3) deg, ``dropped`` (N,) bool, the truth
            columns (``p_c`` kPa, ``R_c`` ohm, ``dR_c`` %, ``strain_c`` %, the actuator's outputs,
            ``load_g`` g), ``g_c`` (%, the contact network's static drop, what ``slow_relaxation``
            acts on) and ``t_plant`` (s).
        """
        dt = float(dt_s)
        setpoint_kpa = np.atleast_2d(np.asarray(setpoint_kpa, dtype=float))
        pump = np.atleast_2d(np.asarray(pump, dtype=bool))
        valve = np.atleast_2d(np.asarray(valve, dtype=bool))
        N = setpoint_kpa.shape[0]
        t = dt * np.arange(1, N + 1)
        ph, eff, n = self.physics, self.effects, self.n_channels
        f, pz, el, pn = ph.foam, ph.piezo, ph.electronics, ph.pneumatics
        rng = np.random.default_rng(self.seed)
        noisy = self.noise
        al = self._alphas(dt)
        if load_g is None:
            load, rest_load = self.load_at(t), self.load_g
        else:
            load = np.asarray(load_g, dtype=float).reshape(N)
            rest_load = float(load[0])
        sigma_load = load_stress_kpa(load, f)
        eps_rest, e_rest = self.rest_state(rest_load)

        def first_order(u, a, y0):
            return lfilter([1.0 - a], [1.0, -a], u, zi=[a * y0])[0]

        out: dict = {}
        reg = ou_series(rng, N, dt, pn.regulator_noise_kpa, pn.regulator_noise_s, (n,)) if noisy else np.zeros((N, n))
        stress = []
        for c in range(n):
            p = pneumatics.run_pressure(dt, setpoint_kpa[:, c], pump[:, c], valve[:, c], ph.pneumatics)
            out[f"p_{c}"] = p
            driven = np.minimum(np.maximum(-p, 0.0) / REGULATOR_FULL_KPA, 1.0)
            stress.append(np.where(p < 0, -(p + reg[:, c] * driven), 0.0) - sigma_load)
        es = self._static_strains(stress)
        eps = np.zeros((N, n))
        eps_c = np.zeros((N, n))
        for c in range(n):
            e = sum(w * first_order(es[c], a, eps_rest[c]) for a, w in zip(al["creep"], f.creep_weight))
            eps[:, c] = e
            eps_c[:, c] = e - self._load_contact[c] * sigma_load
        if "cross_coupling" in eff and n > 1:
            rel = eps - np.asarray(eps_rest)
            eps_c = eps_c + eff["cross_coupling"]["gain"] * (rel.sum(axis=1, keepdims=True) - rel)

        drift = 1.0 + eff["drift"]["rate_pct_per_min"] / 100.0 * t / 60.0 if "drift" in eff else 1.0
        walk = walk_series(rng, N, dt, ph.variation.drift_walk_pct, (n,)) if noisy else np.zeros((N, n))
        flicker = ou_series(rng, N, dt, pz.flicker_pct, pz.flicker_s, (n,)) if noisy else np.zeros((N, n))
        r_seen = np.zeros((N, n))
        for c in range(n):
            d = self.draws[c]
            net = ContactNetwork(d.piezo, self.curves[c].capacity * d.piezo.contact_strain, d.conditioning)
            net.reset(e_rest[c])
            res = net.run(eps_c[:, c], dt)
            dr, g = res["dR"], res["g"]
            if "slow_relaxation" in eff:
                g_rest = net_rest_g(d, self.curves[c], e_rest[c])
                dr = dr + eff["slow_relaxation"]["gain"] * (g - first_order(g, al["slow"], g_rest)) * (1.0 + g / 100.0)
            base = 1.0 + (d.drift_pct_per_min * t / 60.0 + walk[:, c]) / 100.0
            out[f"R_{c}"] = d.r0_ohm * base * (1.0 + dr / 100.0)
            out[f"dR_{c}"] = dr
            out[f"g_{c}"] = g  # the network's static drop (%), what slow_relaxation acts on
            out[f"strain_{c}"] = 100.0 * eps[:, c]
            dr_seen = dr + ((pz.noise_pct * rng.standard_normal(N) + flicker[:, c]) if noisy else 0.0)
            if "periodic_disturbance" in eff:
                pd = eff["periodic_disturbance"]
                dr_seen = dr_seen + pd["amplitude_pct"] * np.sin(
                    2.0 * np.pi * pd["freq_hz"] * t + np.radians(pd["phase_deg"])
                )
            if "outliers" in eff:
                o = eff["outliers"]
                hit = rng.random(N) < o["glitch_prob"]
                dr_seen = dr_seen + hit * o["glitch_pct"] * np.where(rng.random(N) < 0.5, 1.0, -1.0)
            r_seen[:, c] = np.maximum(d.r0_ohm * base * drift * (1.0 + dr_seen / 100.0), 1.0)
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
            wander = ou_series(rng, N, dt, ph.sensors.imu_wander_deg, ph.sensors.imu_wander_s, (3,))
            euler = euler + wander + ph.sensors.imu_noise_deg * rng.standard_normal(euler.shape)
        out["euler_deg"] = np.round(euler / IMU_LSB_DEG) * IMU_LSB_DEG
        out["load_g"] = np.asarray(load, dtype=float) * np.ones(N)
        out["t_plant"] = t
        return out


def net_rest_g(draw, curve: FoamCurve, e_rest: float) -> float:
    """Static dR (%) of a channel's contact network settled at rest at contact strain ``e_rest``."""
    net = ContactNetwork(draw.piezo, curve.capacity * draw.piezo.contact_strain, draw.conditioning)
    net.reset(e_rest)
    return net.g


def make_plant(
    actuator: str,
    porosity=None,
    load_g: float = 0.0,
    seed: int = 0,
    effects=None,
    physics: Physics | None = None,
    noise: bool = True,
    specimen: int = 0,
) -> Plant:
    """A plant of ``actuator`` at rest.

    Parameters
    ----------
    actuator : str
        ``"contractor"``, ``"bending"`` or ``"3dof"``.
    porosity : float or None
        Porosity, % (60-90; None: 82 for the contractor, 84 bending, 76 3-DoF).
    load_g : float
        Hanging load, g (0-500).
    seed : int
        Seed of the recording: its noise and its share of the variation.
    effects : list of str, dict or None
        Named extra effects (see porosense.sim.effects), off by default.
    physics : Physics or None
        Stage parameters to use instead of the defaults (porosense.sim.params).
    noise : bool
        False for noiseless sensors (the realisation drawn from the seeds stays).
    specimen : int
        The printed actuator (porosense.sim.variation).

    Returns
    -------
    Plant
        The plant at rest; ``step`` advances it one sample, ``run`` a whole actuation series.

    Raises
    ------
    InputError
        An unknown actuator or effect, or a porosity or load outside its range.
    """
    return Plant(actuator, porosity, load_g, seed, effects, physics, noise, specimen)
