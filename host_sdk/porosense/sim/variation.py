"""One realisation of an actuator: the parameters of each printed channel and of one recording.

Two levels, each from its own random stream:

- the print (``specimen``): each channel's contact law (scale and amplitude), foam stiffness,
  relaxation gains, kinetics and R0 differ from the nominal values by the relative standard
  deviations of :class:`porosense.sim.params.Variation` (three printed contractors differ);
- the recording (``seed``): the softening state at the start, the R0 drift rate, and a small
  change of sensitivity and R0 since the last recording (temperature, settling).

The paper's duplicates are one print recorded twice: same specimen, two seeds. The draws do not
depend on the sensor noise, so the same seed gives the same realisation with ``noise=False``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from porosense.sim.params import Physics, Piezo

PRINT_STREAM, RECORD_STREAM = 7, 8


@dataclass(frozen=True)
class ChannelDraw:
    """Parameters of one channel of one realisation."""

    piezo: Piezo
    modulus_factor: float  # foam stiffness and collapse stress, x nominal
    r0_ohm: float
    conditioning: float  # softening state at the start (0..1)
    drift_pct_per_min: float  # R0 drift rate, % of R0 per minute


def _factor(rng, sd: float) -> float:
    """A positive multiplicative factor with relative standard deviation ``sd`` (log-normal)."""
    return math.exp(sd * rng.standard_normal() - 0.5 * sd * sd) if sd > 0 else 1.0


def draw_channels(physics: Physics, specimen: int, seed: int, n_channels: int) -> list[ChannelDraw]:
    """The ``n_channels`` channel parameters of print ``specimen`` in recording ``seed``."""
    v, pz = physics.variation, physics.piezo
    printed = np.random.default_rng([int(specimen), PRINT_STREAM])
    recorded = np.random.default_rng([int(seed), RECORD_STREAM])
    out = []
    for _ in range(n_channels):
        kin = _factor(printed, v.kinetics_sd) * _factor(recorded, v.record_kinetics_sd)
        relax = _factor(printed, v.relax_gain_sd)
        scale = _factor(printed, v.contact_strain_sd) * _factor(recorded, v.record_scale_sd)
        floor = _factor(printed, v.floor_sd) * _factor(recorded, v.record_gain_sd)
        modulus = _factor(printed, v.modulus_sd)
        r0 = pz.r0_ohm * _factor(printed, v.r0_sd) * _factor(recorded, v.record_r0_sd)
        p = replace(
            pz,
            contact_strain=pz.contact_strain * scale,
            floor_pct=min(pz.floor_pct * floor, 99.0),
            form_s=pz.form_s * kin,
            break_s=pz.break_s * kin,
            relax_gain=tuple(k * relax for k in pz.relax_gain),
        )
        lo, hi = v.conditioning_range
        out.append(
            ChannelDraw(
                piezo=p,
                modulus_factor=modulus,
                r0_ohm=r0,
                conditioning=float(lo + (hi - lo) * recorded.random()),
                drift_pct_per_min=float(v.drift_pct_per_min_sd * recorded.standard_normal()),
            )
        )
    return out
