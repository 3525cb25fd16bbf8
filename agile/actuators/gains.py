"""Gains from motor armature (BeyondMimic / AGILE): a critically over-damped second-order joint."""

from __future__ import annotations

import math

NATURAL_FREQ_HZ = 10.0
DAMPING_RATIO = 2.0


def armature_gains(armature_kgm2: float, natural_freq_hz: float = NATURAL_FREQ_HZ,
                   damping_ratio: float = DAMPING_RATIO) -> tuple[float, float]:
    """(kp, kd) = (J·ωn², 2·ζ·J·ωn) with ωn = 2π·natural_freq_hz."""
    omega = 2.0 * math.pi * natural_freq_hz
    return armature_kgm2 * omega**2, 2.0 * damping_ratio * armature_kgm2 * omega


def action_scale(effort_limit_nm: float, stiffness: float, fraction: float = 0.25) -> float:
    """Action scale so that a unit action asks for `fraction` of the effort limit: 0.25·τ_lim/kp [rad]."""
    return fraction * effort_limit_nm / stiffness
