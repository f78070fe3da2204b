"""PI gains by lambda (IMC) tuning and the closed-loop step they predict.

Rule (lambda tuning of a PI for an FOPDT, Skogestad's SIMC with tau_c = lambda):

    kp = T / (K (lambda + theta_eff)),   ki = kp / T = 1 / (K (lambda + theta_eff))

with ``theta_eff = theta + Ts / 2`` (the board holds its command for one sample: half a
sample of extra delay). ``lambda`` (``--tau-cl``) is the desired closed-loop time constant, the
one knob: larger is slower and more robust to the plant's gain varying over the stroke.
Gains are in kPa of vacuum per output unit (kp) and per output unit and second (ki).

The prediction closes the loop in discrete time at Ts (python-control) around the fitted
FOPDT with the board's PI (``u[k] = kp e[k] + ki Ts sum(e)``) and the target slew limit, and
reads the settling time (2 % band) and the overshoot from the simulated step.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from porosense.control.plant import Fopdt
from porosense.errors import InputError
from porosense.files import save_figure

RULE = (
    "lambda (IMC) tuning of a PI on the FOPDT: kp = T / (K (tau_cl + theta + Ts/2)), "
    "ki = kp / T; kp in kPa per output unit, ki in kPa per (output unit s)"
)

#: Default closed-loop time constant (s). The contractor's open-loop time constant is about
#: 0.3 s; 0.5 s keeps the integral gain inside the board's fixed-point range (CONTROL_GAINS'
#: ki_q24 is 16 bits: about 5 kPa/(% s) at 50 Hz for the contractor's model) with margin.
DEFAULT_TAU_CL_S = 0.5

#: Settling band: a fraction of the step.
SETTLE_BAND = 0.02


@dataclass(frozen=True)
class PiGains:
    """The board's controller gains (the ControlGains fields).

    Attributes
    ----------
    kp_kpa : float
        kPa of vacuum per output unit of error, finite, >= 0.
    ki_kpa_per_s : float
        kPa of vacuum per (output unit * s), finite, >= 0.
    slew_per_s : float
        Target slew limit, output units per s, finite, > 0.

    Raises
    ------
    InputError
        A gain or slew limit outside those ranges.
    """

    kp_kpa: float
    ki_kpa_per_s: float
    slew_per_s: float

    def __post_init__(self):
        for name in ("kp_kpa", "ki_kpa_per_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"{name} = {v} must be a finite number >= 0")
        if not (math.isfinite(self.slew_per_s) and self.slew_per_s > 0):
            raise InputError(f"slew_per_s = {self.slew_per_s} must be a finite number > 0")

    def to_dict(self) -> dict:
        """The fields as a plain dict.

        Returns
        -------
        dict
            ``kp_kpa``, ``ki_kpa_per_s``, ``slew_per_s``.
        """
        return asdict(self)


def lambda_pi(plant: Fopdt, tau_cl_s: float, slew_per_s: float) -> PiGains:
    """PI gains by lambda tuning (the module's rule).

    Parameters
    ----------
    plant : Fopdt
        The fitted plant.
    tau_cl_s : float
        Desired closed-loop time constant, s (> 0).
    slew_per_s : float
        Target slew limit to carry into the gains, output units per s.

    Returns
    -------
    PiGains
        kp = T / (K (tau_cl + theta + Ts/2)), ki = kp / T.

    Raises
    ------
    InputError
        A closed-loop time constant that is not a positive number.
    """
    if not (math.isfinite(tau_cl_s) and tau_cl_s > 0):
        raise InputError(f"--tau-cl {tau_cl_s} s must be a positive number of seconds")
    theta_eff = plant.theta + plant.ts / 2.0
    kp = plant.T / (plant.K * (tau_cl_s + theta_eff))
    return PiGains(kp, kp / plant.T, slew_per_s)


@dataclass
class StepPrediction:
    """Predicted closed-loop response to a target step at t = 0.

    Attributes
    ----------
    t : ndarray
        Time, s, every plant sample period.
    target : ndarray
        The slew-limited target, output units.
    y : ndarray
        Predicted output, output units.
    u : ndarray
        Vacuum command, kPa.
    step : float
        Step size, output units.
    settling_s : float
        Time of the last entry into the 2 % band, s (nan when it never settles).
    overshoot_pct : float
        Overshoot, % of the step.
    peak_vacuum_kpa : float
        Largest |u|, kPa.
    """

    t: np.ndarray
    target: np.ndarray
    y: np.ndarray
    u: np.ndarray
    step: float
    settling_s: float
    overshoot_pct: float
    peak_vacuum_kpa: float

    def summary(self) -> dict:
        """The step's figures without the series.

        Returns
        -------
        dict
            ``step`` (output units), ``settling_s`` (s), ``overshoot_pct`` (%), ``peak_vacuum_kpa``.
        """
        return {
            "step": self.step,
            "settling_s": self.settling_s,
            "overshoot_pct": self.overshoot_pct,
            "peak_vacuum_kpa": self.peak_vacuum_kpa,
        }

    def plot(self, path, title: str = "predicted closed-loop step") -> None:
        """Draw the predicted step (target, output and 2 % band above, vacuum command below) into a file.

        Parameters
        ----------
        path : str or Path
            The image file.
        title : str
            Figure title.
        """
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, (ax, ax2) = plt.subplots(2, 1, sharex=True, figsize=(7, 5), height_ratios=(2, 1))
        ax.plot(self.t, self.target, "k--", label="target (slew-limited)")
        ax.plot(
            self.t,
            self.y,
            label=f"predicted output (settles in {self.settling_s:.2f} s, overshoot {self.overshoot_pct:.1f} %)",
        )
        ax.axhspan(self.step * (1 - SETTLE_BAND), self.step * (1 + SETTLE_BAND), color="0.9")
        ax.set_ylabel("output")
        ax.legend(loc="lower right", fontsize=8)
        ax.set_title(title)
        ax2.plot(self.t, self.u, color="C3")
        ax2.set_ylabel("vacuum command (kPa)")
        ax2.set_xlabel("time (s)")
        fig.tight_layout()
        save_figure(fig, path, dpi=110)
        plt.close(fig)


def settling_and_overshoot(t, y, step: float, t_final_target: float = 0.0) -> tuple[float, float]:
    """Settling time (s, from t = 0 until ``y`` last enters the 2 % band of ``step`` around its
    final value ``step``) and overshoot (% of the step). NaN settling when it never settles."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if step == 0:
        raise InputError("a step of 0 has no settling time")
    err = np.abs(y - step) > SETTLE_BAND * abs(step)
    if err[-1]:
        settling = float("nan")
    else:
        outside = np.flatnonzero(err)
        settling = float(t[outside[-1] + 1] - t[0]) if outside.size else 0.0
    over = max(0.0, float(np.max((y - step) * np.sign(step))) / abs(step) * 100.0)
    return settling, over


def predict_step(
    plant: Fopdt, gains: PiGains, step: float, *, duration_s: float | None = None, max_vacuum_kpa: float | None = None
) -> StepPrediction:
    """Closed-loop response of ``plant`` under ``gains`` to a slew-limited target step.

    Linear unless ``max_vacuum_kpa`` is given; then the command is clipped to 0..max_vacuum_kpa
    and the integral held while clipped, as on the board.

    Parameters
    ----------
    plant : Fopdt
        The plant; the loop runs at its sample period.
    gains : PiGains
        Controller gains; the target rises at ``gains.slew_per_s``.
    step : float
        Target step, output units (not 0).
    duration_s : float or None
        Length of the prediction, s (None: long enough to settle, from the plant and gains).
    max_vacuum_kpa : float or None
        Largest vacuum command, kPa (None: no limit).

    Returns
    -------
    StepPrediction
        The response, its settling time and overshoot.

    Raises
    ------
    InputError
        A step of 0.
    """
    import control

    ts = plant.ts
    if duration_s is None:
        # the loop's own time constant is about 1 / (K ki) (= tau_cl + theta_eff under the rule)
        tau_loop = 1.0 / (plant.K * gains.ki_kpa_per_s) if gains.ki_kpa_per_s > 0 else 10.0 * plant.T
        duration_s = 5.0 * (plant.T + plant.theta) + 8.0 * tau_loop + abs(step) / gains.slew_per_s
    n = int(math.ceil(duration_s / ts)) + 1
    t = np.arange(n) * ts
    r = np.sign(step) * np.minimum(abs(step), gains.slew_per_s * t)
    G = plant.to_control()
    if max_vacuum_kpa is None:
        C = control.tf([gains.kp_kpa + gains.ki_kpa_per_s * ts, -gains.kp_kpa], [1.0, -1.0], ts)
        loop = control.feedback(C * G, 1)
        y = np.asarray(control.forced_response(loop, T=t, U=r).outputs).ravel()
        u = np.asarray(control.forced_response(control.feedback(C, G), T=t, U=r).outputs).ravel()
    else:
        y, u = _simulate_saturated(plant, gains, r, max_vacuum_kpa)
    settling, over = settling_and_overshoot(t, y, step)
    return StepPrediction(t, r, y, u, float(step), settling, over, float(np.max(np.abs(u))))


def _simulate_saturated(plant: Fopdt, gains: PiGains, r, max_vacuum_kpa):
    """The loop sample by sample with the command clipped to 0..max_vacuum_kpa and the integral
    held while clipped (conditional integration)."""
    a = math.exp(-plant.ts / plant.T)
    d = plant.delay_samples
    n = len(r)
    y = np.zeros(n)
    u = np.zeros(n)
    x, integ = 0.0, 0.0
    for k in range(n):
        y[k] = x
        e = r[k] - y[k]
        raw = gains.kp_kpa * e + integ + gains.ki_kpa_per_s * plant.ts * e
        u[k] = min(max(raw, 0.0), max_vacuum_kpa)
        if raw == u[k]:
            integ += gains.ki_kpa_per_s * plant.ts * e
        v = u[k - d] if k - d >= 0 else 0.0
        x = a * x + plant.K * (1 - a) * v
    return y, u


def board_tau_cl(plant: Fopdt, tau_cl_s: float, slew_per_s: float, out_scale: float, rate_hz: float) -> float:
    """The smallest closed-loop time constant (s), at least ``tau_cl_s``, whose gains the board's
    fixed point holds for a model with ``out_scale`` (output units per LSB) at ``rate_hz``: kp
    and ki both fall as tau_cl grows, so a bisection against the board's own conversion
    (porosense.device.control.to_fixed) finds it."""
    from porosense.device.control import ControlGains, to_fixed

    def holds(tau: float) -> bool:
        g = lambda_pi(plant, tau, slew_per_s)
        try:
            to_fixed(ControlGains(g.kp_kpa, g.ki_kpa_per_s, g.slew_per_s), (out_scale,), rate_hz)
        except InputError:
            return False
        return True

    if holds(tau_cl_s):
        return float(tau_cl_s)
    lo, hi = float(tau_cl_s), max(2.0 * tau_cl_s, 1.0)
    while not holds(hi):
        lo, hi = hi, 2.0 * hi
        if hi > 1e4:
            raise InputError("no closed-loop time constant gives gains the board can hold for this model")
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if holds(mid) else (mid, hi)
    return hi
