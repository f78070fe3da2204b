"""An independent hidden-effect generator for scoring diagnosis.

Written apart from the detector (porosense.diagnose) and from the actuator simulator
(porosense.sim): it imports neither, has its own nominal system and its own effect shapes, and
draws every parameter from wide ranges. Diagnosis is scored on it; its constants must never
be tuned to make the detector pass.

The nominal system is a generic sensor path: a positive input u (a level signal in [0, A] with
random holds, ramps and chirps, like a pressure programme) through a stable continuous-time
system of order 1 to 3 with real or complex poles (dominant time constant 0.1-1.5 s), sampled
at 6-25 samples per dominant time constant, plus white output noise at 0.4-2 % of the output
span. Every record also carries two extra columns that the nominal model does not use, in
every trial, so that their presence tells nothing: ``u_aux`` (another channel's command) and
``load`` (a piecewise-constant load in kg).

Effects and their shapes (strength ranges in :data:`STRENGTHS`):

- static_nonlinearity: an exponential or logarithmic map on the input or the output side;
- hysteresis: mechanical backlash on the input, or a Bouc-Wen loop on the output;
- slow_relaxation: a parallel creep or relaxation branch 8-40 times slower than the dominant pole;
- time_delay: a transport delay of 2-12 samples;
- drift: an integrated random walk plus a linear trend, unrelated to any input;
- periodic_disturbance: a square or triangle wave at a random frequency;
- load_dependence: the gain (and an offset) scheduled by the load column;
- saturation: the measured output clipped at a sensor limit after the noise;
- cross_coupling: u_aux leaks in through its own slow filter;
- outliers: isolated glitches and short bursts;
- unmodelled_dynamics: the system has more poles than the nominal order it is given.

False-alarm trials (expected answer ``none``): clean data at the true order, clean data
quantised in steps of 0.5-2 % of the span, and clean data with coloured (AR(1)) noise.

Usage::

    trial = draw_trial("hysteresis", seed=7)
    trial.estimation["u"], trial.estimation["y"], trial.nominal_order, trial.expected
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

#: Causes hidden by this generator (the catalogue's names plus unmodelled_dynamics).
CAUSES = (
    "static_nonlinearity",
    "hysteresis",
    "slow_relaxation",
    "time_delay",
    "drift",
    "periodic_disturbance",
    "load_dependence",
    "saturation",
    "cross_coupling",
    "outliers",
    "unmodelled_dynamics",
)
#: Clean variants whose right answer is ``none``.
FALSE_ALARM_KINDS = ("clean", "clean_quantised", "clean_coloured_noise")

#: What each trial draws, in words (the figures are the ranges drawn uniformly).
STRENGTHS = {
    "static_nonlinearity": "exp or log map, curvature b in [1.2, 3.5] on the normalised input or output",
    "hysteresis": "backlash of 8-25 % of the input span, or a Bouc-Wen loop weighing 25-50 % of the output",
    "slow_relaxation": "parallel branch of 15-40 % of the gain, 8-40x slower than the dominant pole, either sign",
    "time_delay": "2-12 samples of transport delay (at least 20 % of the dominant time constant)",
    "drift": "random walk plus trend reaching 4-12 % of the output span over the record",
    "periodic_disturbance": "square or triangle wave of 2-7 % of the span at 2-25 % of the sample rate",
    "load_dependence": "gain falls by 12-35 % at the largest load, offset up to 3 % of span",
    "saturation": "output clipped at the level exceeded by 6-20 % of the samples, top or bottom",
    "cross_coupling": "u_aux through a first-order filter 1-4x slower, 12-35 % of the main gain",
    "outliers": "0.2-1 % of samples hit by glitches of 20-80 % of span, bursts of 1-3 samples",
    "unmodelled_dynamics": "true order 2-3 with the extra poles within 1.5-6x of the dominant one; "
    "nominal order one less",
    "clean": "no effect",
    "clean_quantised": "output quantised in steps of 0.5-2 % of the span",
    "clean_coloured_noise": "AR(1) output noise, pole 0.6-0.95, same variance range",
}


@dataclass
class Trial:
    """One hidden-effect trial: two records, what is hidden and the order to give the nominal model.

    ``estimation`` and ``validation`` map column names to arrays: ``u`` (the input the nominal
    model uses), ``y`` (the measured output), ``u_aux`` and ``load`` (extra columns present in
    every trial). ``ts`` is the sample period in s. ``expected`` is the cause a diagnosis should
    name first (``none`` for false-alarm kinds). ``nominal_order`` is the number of poles to give
    the nominal linear model (the true order, except for unmodelled_dynamics). ``effect_to_noise``
    is the RMS of what the effect adds to the output divided by the noise RMS, on validation.
    """

    kind: str
    expected: str
    seed: int
    ts: float
    estimation: dict
    validation: dict
    true_order: int
    nominal_order: int
    params: dict = field(default_factory=dict)
    effect_to_noise: float = float("nan")

    input_columns: tuple = ("u",)
    output_column: str = "y"
    condition_columns: tuple = ("u_aux", "load")

    def __repr__(self) -> str:
        return (
            f"Trial({self.kind}, seed={self.seed}, ts={self.ts:.4g} s, order {self.true_order} "
            f"(nominal {self.nominal_order}), effect/noise {self.effect_to_noise:.2f}, {self.params})"
        )


# --- the nominal system ------------------------------------------------------------------------


@dataclass
class _System:
    num: np.ndarray  # discrete transfer function from u to the noiseless output
    den: np.ndarray
    ts: float
    tau: float  # dominant time constant, s
    order: int
    gain: float  # static gain

    def response(self, u: np.ndarray) -> np.ndarray:
        # start at rest with the input's first value held before t = 0
        zi = signal.lfilter_zi(self.num, self.den) * u[0]
        return signal.lfilter(self.num, self.den, u, zi=zi)[0]


def _continuous_poles(rng, order: int, tau: float, spread=(1.5, 6.0)) -> list[complex]:
    """Poles (rad/s) with the dominant one at -1/tau and the others faster."""
    poles = []
    if order >= 2 and rng.random() < 0.4:
        # a complex dominant pair, damping 0.45-0.9
        zeta, wn = rng.uniform(0.45, 0.9), 1.0 / (tau * rng.uniform(0.45, 0.9))
        wd = wn * np.sqrt(1 - zeta**2)
        poles += [complex(-zeta * wn, wd), complex(-zeta * wn, -wd)]
    else:
        poles.append(complex(-1.0 / tau, 0))
    while len(poles) < order:
        poles.append(complex(-rng.uniform(*spread) / tau, 0))
    return poles[:order]


def _system(rng, order: int, tau: float, ts: float, gain: float) -> _System:
    poles = _continuous_poles(rng, order, tau)
    den_c = np.real(np.poly(poles))
    num_c = np.array([den_c[-1] * gain])
    num_d, den_d, _ = signal.cont2discrete((num_c, den_c), ts, method="zoh")
    num_d = np.atleast_1d(np.squeeze(num_d))
    # remove numerical leading zeros but keep the one-sample delay of a ZOH
    return _System(num_d, den_d, ts, tau, order, gain)


def _first_order(tau: float, ts: float, gain: float = 1.0):
    a = np.exp(-ts / tau)
    return np.array([0.0, gain * (1 - a)]), np.array([1.0, -a])


def _filter_from_rest(b, a, x):
    zi = signal.lfilter_zi(b, a) * x[0]
    return signal.lfilter(b, a, x, zi=zi)[0]


# --- signals ------------------------------------------------------------------------------------


def _programme(rng, n: int, ts: float, tau: float, amp: float) -> np.ndarray:
    """A level programme in [0, amp]: holds of 1-8 tau, some ramps, an occasional chirp."""
    out = np.empty(n)
    k, level = 0, 0.0
    while k < n:
        m = max(2, int(rng.uniform(1.0, 8.0) * tau / ts))
        target = rng.uniform(0.0, amp) if rng.random() > 0.15 else 0.0
        shape = rng.random()
        seg = np.full(m, target)
        if shape < 0.25:  # ramp
            seg = np.linspace(level, target, m)
        elif shape < 0.32:  # chirp around the middle
            t = np.arange(m) * ts
            f0, f1 = 0.05 / tau, 0.6 / tau
            seg = amp * (0.5 + 0.4 * np.sin(2 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2 * t[-1] + ts))))
        out[k : k + m] = seg[: n - k]
        level = out[min(k + m, n) - 1]
        k += m
    return out


def _load(rng, n: int) -> np.ndarray:
    levels = np.array([0.0, 0.1, 0.2, 0.35, 0.5])
    cuts = np.sort(rng.choice(np.arange(n // 8, n - n // 8), size=rng.integers(2, 6), replace=False))
    out = np.empty(n)
    start = 0
    for c in list(cuts) + [n]:
        out[start:c] = rng.choice(levels)
        start = c
    return out


# --- effect shapes ------------------------------------------------------------------------------


def _exp_map(x: np.ndarray, lo: float, hi: float, b: float, log: bool) -> np.ndarray:
    """Monotone exp (or its inverse, log) map of [lo, hi] onto itself, curvature b."""
    span = hi - lo or 1.0
    v = np.clip((x - lo) / span, -0.2, 1.2)
    if log:
        w = np.log1p(v * (np.exp(b) - 1)) / b
    else:
        w = np.expm1(b * v) / np.expm1(b)
    return lo + span * w


def _backlash(x: np.ndarray, width: float) -> np.ndarray:
    out = np.empty_like(x)
    y = x[0]
    h = width / 2
    for k, xk in enumerate(x):
        if xk - y > h:
            y = xk - h
        elif y - xk > h:
            y = xk + h
        out[k] = y
    return out


def _bouc_wen(x: np.ndarray, span: float, sharp: float) -> np.ndarray:
    """Rate-independent Bouc-Wen loop z of the signal x (same units), saturating at ~span/2."""
    z = np.empty_like(x)
    zk, a = 0.0, 1.0
    beta = gamma = sharp / (span / 2)
    prev = x[0]
    for k, xk in enumerate(x):
        dx = xk - prev
        zk += a * dx - beta * abs(dx) * zk - gamma * dx * abs(zk)
        z[k] = zk
        prev = xk
    return z


def _square(t, f, phase, duty):
    return np.where(((t * f + phase) % 1.0) < duty, 1.0, -1.0)


def _triangle(t, f, phase):
    return 2 * np.abs(2 * ((t * f + phase) % 1.0) - 1) - 1


# --- trials -------------------------------------------------------------------------------------


def draw_trial(kind: str, seed: int) -> Trial:
    """One trial of ``kind`` (a cause in :data:`CAUSES` or a :data:`FALSE_ALARM_KINDS` entry).

    The same (kind, seed) always gives the same data.
    """
    if kind not in CAUSES and kind not in FALSE_ALARM_KINDS:
        raise ValueError(f"unknown trial kind {kind!r}; choose from {CAUSES + FALSE_ALARM_KINDS}")
    rng = np.random.default_rng([seed, CAUSES.index(kind) if kind in CAUSES else 100 + FALSE_ALARM_KINDS.index(kind)])
    tau = rng.uniform(0.1, 1.5)
    ts = tau / rng.uniform(6.0, 25.0)
    amp = rng.uniform(10.0, 80.0)
    gain = rng.uniform(0.3, 3.0) * rng.choice([-1.0, 1.0])
    if kind == "unmodelled_dynamics":
        order = int(rng.integers(2, 4))
    else:
        order = int(rng.integers(1, 3))
    sys_ = _system(rng, order, tau, ts, gain)
    n_est = int(rng.integers(2400, 4800))
    n_val = int(rng.integers(1200, 2400))
    noise_frac = rng.uniform(0.004, 0.02)
    span = abs(gain) * amp
    params = _draw_params(rng, kind, ts, tau, span, amp)
    est, e_eff, e_noise = _record(rng, kind, params, sys_, n_est, amp, span, noise_frac)
    val, v_eff, v_noise = _record(rng, kind, params, sys_, n_val, amp, span, noise_frac)
    nominal = order - 1 if kind == "unmodelled_dynamics" else order
    expected = "none" if kind in FALSE_ALARM_KINDS else kind
    params.update({"order": order, "tau_s": round(tau, 4), "gain": round(gain, 4), "noise_frac": round(noise_frac, 4)})
    return Trial(
        kind,
        expected,
        seed,
        ts,
        est,
        val,
        order,
        nominal,
        params,
        float(np.sqrt(np.mean(v_eff**2)) / (np.sqrt(np.mean(v_noise**2)) or 1.0)),
    )


def _draw_params(rng, kind, ts, tau, span, amp) -> dict:
    u = rng.uniform
    if kind == "static_nonlinearity":
        return {"b": u(1.2, 3.5), "side": str(rng.choice(["input", "output"])), "log": bool(rng.random() < 0.5)}
    if kind == "hysteresis":
        if rng.random() < 0.5:
            return {"shape": "backlash", "width": u(0.08, 0.25) * amp}
        return {"shape": "bouc_wen", "weight": u(0.25, 0.5), "sharp": u(1.5, 4.0)}
    if kind == "slow_relaxation":
        return {"share": u(0.15, 0.4) * rng.choice([-1.0, 1.0]), "tau_slow": tau * u(8.0, 40.0)}
    if kind == "time_delay":
        lo = max(2, int(np.ceil(0.2 * tau / ts)))
        return {"delay": int(rng.integers(lo, max(lo + 1, 13)))}
    if kind == "drift":
        return {"reach": u(0.04, 0.12), "trend_share": u(0.0, 0.6)}
    if kind == "periodic_disturbance":
        return {
            "shape": str(rng.choice(["square", "triangle"])),
            "amp": u(0.02, 0.07),
            "f_hz": u(0.02, 0.25) / ts,
            "duty": u(0.3, 0.7),
        }
    if kind == "load_dependence":
        return {"drop": u(0.12, 0.35), "offset": u(-0.03, 0.03)}
    if kind == "saturation":
        return {"fraction": u(0.06, 0.2), "side": str(rng.choice(["top", "bottom"]))}
    if kind == "cross_coupling":
        return {"share": u(0.12, 0.35) * rng.choice([-1.0, 1.0]), "slower": u(1.0, 4.0)}
    if kind == "outliers":
        return {"rate": u(0.002, 0.01), "size": (0.2, 0.8)}
    if kind == "clean_quantised":
        return {"step": u(0.005, 0.02)}
    if kind == "clean_coloured_noise":
        return {"pole": u(0.6, 0.95)}
    return {}


def _record(rng, kind, p, sys_: _System, n, amp, span, noise_frac):
    """(columns, effect contribution, noise) for one record."""
    ts, tau = sys_.ts, sys_.tau
    u = _programme(rng, n, ts, tau, amp)
    u_aux = _programme(rng, n, ts, tau * rng.uniform(0.7, 1.5), amp)
    load = _load(rng, n)
    clean = sys_.response(u)
    x = u
    if kind == "static_nonlinearity" and p["side"] == "input":
        x = _exp_map(u, 0.0, amp, p["b"], p["log"])
    if kind == "hysteresis" and p["shape"] == "backlash":
        x = _backlash(u, p["width"])
    if kind == "time_delay":
        x = np.concatenate([np.full(p["delay"], u[0]), u[: -p["delay"]]])
    y = sys_.response(x)
    lo, hi = sorted((0.0, sys_.gain * amp))
    if kind == "static_nonlinearity" and p["side"] == "output":
        y = _exp_map(y, lo, hi, p["b"], p["log"])
    if kind == "hysteresis" and p["shape"] == "bouc_wen":
        # the Bouc-Wen form (1 - w) y + w z with the hysteretic variable z at rest (0) where the
        # record starts: causal (no later sample is used) and the same law in every record
        z = _bouc_wen(y, span, p["sharp"])
        y = (1 - p["weight"]) * y + p["weight"] * z
    if kind == "slow_relaxation":
        b, a = _first_order(p["tau_slow"], ts)
        y = y + p["share"] * (_filter_from_rest(b, a, y) - y)
    if kind == "load_dependence":
        scale = 1 - p["drop"] * load / 0.5
        y = y * scale + p["offset"] * span * load / 0.5
    if kind == "cross_coupling":
        b, a = _first_order(tau * p["slower"], ts, sys_.gain * p["share"])
        y = y + _filter_from_rest(b, a, u_aux) - b.sum() / a.sum() * u_aux[0]
    t = np.arange(n) * ts
    if kind == "drift":
        walk = np.cumsum(rng.normal(0, 1, n))
        trend = np.linspace(0, 1, n) * rng.choice([-1, 1])
        walk = walk / (np.max(np.abs(walk)) or 1)
        d = (1 - p["trend_share"]) * walk + p["trend_share"] * trend
        y = y + p["reach"] * span * d / (np.max(np.abs(d)) or 1)
    if kind == "periodic_disturbance":
        ph = rng.random()
        w = _square(t, p["f_hz"], ph, p["duty"]) if p["shape"] == "square" else _triangle(t, p["f_hz"], ph)
        y = y + p["amp"] * span * w
    if kind == "clean_coloured_noise":
        e = rng.normal(0, 1, n)
        noise = signal.lfilter([1.0], [1.0, -p["pole"]], e)
        noise *= noise_frac * span / np.std(noise)
    else:
        noise = rng.normal(0, noise_frac * span, n)
    # for unmodelled_dynamics the effect is the system itself: it shows only against the nominal
    # order, so the contribution is reported as nan
    effect = np.full(n, np.nan) if kind == "unmodelled_dynamics" else y - clean
    meas = y + noise
    if kind == "saturation":
        q = 1 - p["fraction"] if p["side"] == "top" else p["fraction"]
        limit = np.quantile(meas, q)
        meas = np.minimum(meas, limit) if p["side"] == "top" else np.maximum(meas, limit)
        effect = meas - (clean + noise)
    if kind == "outliers":
        hits = np.flatnonzero(rng.random(n) < p["rate"])
        for k in hits:
            width = int(rng.integers(1, 4))
            meas[k : k + width] += rng.choice([-1, 1]) * rng.uniform(*p["size"]) * span
        effect = meas - (y + noise)
    if kind == "clean_quantised":
        step = p["step"] * span
        meas = np.round(meas / step) * step
    return {"u": u, "y": meas, "u_aux": u_aux, "load": load}, effect, noise


def trials(kinds=CAUSES + FALSE_ALARM_KINDS, n_per_kind: int = 10, seed: int = 20261124):
    """Yield ``n_per_kind`` trials of every kind, seeds ``seed``, ``seed + 1``, ..."""
    for kind in kinds:
        for k in range(n_per_kind):
            yield draw_trial(kind, seed + k)
