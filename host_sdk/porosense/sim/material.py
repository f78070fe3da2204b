"""The piezoresistive law of the carbon-black network: contact strain (fraction) -> dR (%).

One channel, stepped one sample at a time (:meth:`ContactNetwork.step`) or run over a whole
series (:meth:`ContactNetwork.run`, the same equations). Stages, each one a named effect of
:data:`porosense.sim.params.PHYSICS_EFFECTS` that can be switched off:

1. contact formation (static): at contact strain ``e`` the share of closed tunnelling gaps in
   equilibrium is ``x_eq = 1 - exp(-(e / scale)^q)`` (0 in tension);
2. contact kinetics (``rate_hysteresis``): the contacts follow ``x_eq`` with an instantaneous
   share ``r`` and a first-order rest whose time constant depends on the direction, ``form_s``
   while contacts form and ``break_s`` while they break. Two directions at two speeds make the
   loops rate dependent (a fast step leaves a wide loop, a slow ramp a thin one) while the
   steady state stays history free; switched off, ``break_s = form_s`` (a linear lag);
3. softening (``softening``): each loading path conditions the network (Mullins-like), a
   state ``c`` growing by ``dx (1 - c) / soften_cycles`` while contacts form, and the
   sensitivity falls to ``1 - soften_fraction c``;
4. static resistance drop ``g = -D s x`` (``D = floor_pct``, ``s`` the softened sensitivity);
   tension (a load stretching the foam) raises R with a gauge factor;
5. network relaxation (``relaxation``): after a change the network re-forms with two time
   constants: in the log domain ``L = h + sum_i k_i (h - LP_i(h))``, ``h = ln(1 + g/100)``,
   ``dR = 100 (exp(L) - 1)``. After a release R overshoots above R0 by ``exp(k |h|) - 1``
   and relaxes back; under load the relative undershoot is small. With ``relax_log`` off the
   relaxation is additive in dR (``dR = g + sum_i k_i (g - LP_i(g))``), a linear block.

A measured static curve (``curve_strain``, ``curve_log_r``: the settled ln(R / R0) at those
strains, linear in between and beyond) replaces stages 1 and 4 when the law is calibrated from
a tensile test (porosense.sim.calibrate): the kinetics, softening and relaxation then act on
ln(R / R0).

With rate hysteresis, softening and the log-domain relaxation off, dR -> strain is a Wiener
model (linear relaxation, linear lag, static inverse contact curve) that a WH model contains.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import lfilter

from porosense.sim.params import Piezo

_TINY = 1e-300


def equilibrium_contacts(e, scale: float, exponent: float):
    """Equilibrium share of closed contacts (0..1) at contact strain ``e`` (fraction)."""
    e = np.asarray(e, dtype=float)
    out = -np.expm1(-((np.maximum(e, 0.0) / scale) ** exponent))
    return float(out) if out.ndim == 0 else out


def static_dr(e, p: Piezo, scale: float, sensitivity: float = 1.0):
    """Settled dR (%) at contact strain ``e`` without relaxation or softening history.

    ``scale``: contact strain (fraction) at which 63 % of the contacts are closed;
    ``sensitivity``: the softened share of ``floor_pct`` (1: virgin network).
    """
    e = np.asarray(e, dtype=float)
    out = np.where(
        e >= 0.0,
        -p.floor_pct * sensitivity * equilibrium_contacts(e, scale, p.contact_exponent),
        -100.0 * p.tension_gauge_factor * e,
    )
    return float(out) if out.ndim == 0 else out


def measured_curve(e, xs, ys):
    """Piecewise-linear curve through (``xs``, ``ys``), extended beyond both ends with the
    slope of its end segments (a tensile test beyond the strains it was calibrated on)."""
    e = np.asarray(e, dtype=float)
    out = np.interp(e, xs, ys)
    if len(xs) > 1:
        lo = (ys[1] - ys[0]) / (xs[1] - xs[0])
        hi = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
        out = np.where(e < xs[0], ys[0] + lo * (e - xs[0]), np.where(e > xs[-1], ys[-1] + hi * (e - xs[-1]), out))
    return float(out) if out.ndim == 0 else out


class ContactNetwork:
    """State and equations of one channel's piezoresistive law (see the module docstring).

    Parameters
    ----------
    p : Piezo
        The law's parameters (time constants in s, gains as fractions, dR in %).
    scale : float
        Contact strain (fraction) at which 63 % of the contacts are closed in equilibrium.
    conditioning : float
        Softening state at rest before the first sample (0 virgin .. 1 fully conditioned).
    """

    def __init__(self, p: Piezo, scale: float, conditioning: float = 0.0):
        self.p, self.scale = p, float(scale)
        self.c0 = float(conditioning)
        self.n_relax = len(p.relax_s)
        self._alpha: dict = {}
        self.reset(0.0)

    # --- constants per sample period -------------------------------------------------------
    def alphas(self, dt: float) -> tuple:
        a = self._alpha.get(dt)
        if a is None:
            p = self.p
            a = (
                math.exp(-dt / p.form_s),
                math.exp(-dt / p.break_s),
                tuple(math.exp(-dt / tau) for tau in p.relax_s),
                math.exp(-dt / p.soften_heal_s),
            )
            if len(self._alpha) > 64:
                self._alpha.clear()
            self._alpha[dt] = a
        return a

    def _x_eq(self, e):
        """Equilibrium state at strain(s) ``e``: the share of closed contacts, or with a
        measured curve (``curve_strain``) the settled ln(R / R0)."""
        p = self.p
        if p.curve_strain:
            return measured_curve(e, p.curve_strain, p.curve_log_r)
        return equilibrium_contacts(e, self.scale, p.contact_exponent)

    def _g(self, x: float, e: float, c: float) -> float:
        p = self.p
        if p.curve_strain:
            return 100.0 * math.expm1((1.0 - p.soften_fraction * c) * x)
        if e < 0.0:
            return -100.0 * p.tension_gauge_factor * e
        return -p.floor_pct * (1.0 - p.soften_fraction * c) * x

    def _h(self, g: float) -> float:
        return math.log(max(1.0 + g / 100.0, 1e-9)) if self.p.relax_log else g

    def reset(self, e_rest: float) -> None:
        """At rest at contact strain ``e_rest`` (fraction), settled."""
        x = float(self._x_eq(e_rest))
        self.x_slow, self.x, self.c = x, x, self.c0
        h = self._h(self._g(x, e_rest, self.c))
        self.lp = [h] * self.n_relax
        self.g = self._g(x, e_rest, self.c)

    # --- one sample ----------------------------------------------------------------------
    def step(self, e: float, dt: float) -> float:
        """Advance one sample at contact strain ``e`` (fraction); returns dR (%)."""
        p = self.p
        a_f, a_b, a_r, a_h = self.alphas(dt)
        if p.curve_strain:
            x_eq = float(self._x_eq(e))
        else:
            x_eq = -math.expm1(-((e / self.scale) ** p.contact_exponent)) if e > 0.0 else 0.0
        d = x_eq - self.x_slow
        self.x_slow += (1.0 - (a_f if d > 0.0 else a_b)) * d
        x = p.instant_share * x_eq + (1.0 - p.instant_share) * self.x_slow
        self.c *= a_h
        if x > self.x:
            self.c += (x - self.x) * (1.0 - self.c) / p.soften_cycles
        self.x = x
        g = self._g(x, e, self.c)
        self.g = g
        h = self._h(g)
        out = h
        for i, (a, k) in enumerate(zip(a_r, p.relax_gain)):
            self.lp[i] = a * self.lp[i] + (1.0 - a) * h
            out += k * (h - self.lp[i])
        return 100.0 * math.expm1(out) if p.relax_log else out

    # --- a whole series ------------------------------------------------------------------
    def run(self, e, dt: float) -> dict:
        """dR (%) for each sample of contact strain ``e`` (fraction), from the current state.

        Returns ``dR``, the static drop ``g`` (%) and the contact share ``x``; the state moves
        to the end of the series.
        """
        p = self.p
        e = np.asarray(e, dtype=float)
        a_f, a_b, a_r, a_h = self.alphas(dt)
        x_eq = np.asarray(self._x_eq(e), dtype=float).tolist()
        r, r1, gf, gb = p.instant_share, 1.0 - p.instant_share, 1.0 - a_f, 1.0 - a_b
        xs, xp, c = self.x_slow, self.x, self.c
        inv_n = 1.0 / p.soften_cycles
        x_out: list = []
        c_out: list = []
        keep_x, keep_c = x_out.append, c_out.append
        # The contact kinetics are nonlinear (the rate depends on the direction, the softening on
        # the path): one sample at a time, in as few Python operations as the arithmetic allows.
        for xe in x_eq:
            d = xe - xs
            if d > 0.0:
                xs += gf * d
            else:
                xs += gb * d
            x = r * xe + r1 * xs
            c *= a_h
            if x > xp:
                c += (x - xp) * (1.0 - c) * inv_n
            xp = x
            keep_x(x)
            keep_c(c)
        self.x_slow, self.x, self.c = xs, xp, c
        x = np.asarray(x_out, dtype=float)
        sens = 1.0 - p.soften_fraction * np.asarray(c_out, dtype=float)  # softened sensitivity
        if p.curve_strain:
            g = 100.0 * np.expm1(sens * x)
        else:
            g = np.where(e >= 0.0, -p.floor_pct * sens * x, -100.0 * p.tension_gauge_factor * e)
        h = np.log(np.maximum(1.0 + g / 100.0, 1e-9)) if p.relax_log else g
        out = h.copy()
        for i, (a, k) in enumerate(zip(a_r, p.relax_gain)):
            lp = lfilter([1.0 - a], [1.0, -a], h, zi=[a * self.lp[i]])[0]
            self.lp[i] = float(lp[-1]) if lp.size else self.lp[i]
            out += k * (h - lp)
        if g.size:
            self.g = float(g[-1])
        dr = 100.0 * np.expm1(out) if p.relax_log else out
        return {"dR": dr, "g": g, "x": x}
