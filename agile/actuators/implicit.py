"""Implicit PD actuator: the gains are handed to the solver, which integrates the PD force implicitly."""

from __future__ import annotations

from dataclasses import field

from agile.utils.config import configclass

JointValue = float | dict[str, float]
"""One value for every joint of the group, or {joint-name regex: value}."""


@configclass
class ImplicitActuatorCfg:
    """PD gains in the solver (MuJoCo position actuator), as Isaac Lab's `ImplicitActuatorCfg`.

    `None` keeps what the robot's model file says.
    """

    joint_names_expr: list[str] = field(default_factory=lambda: [".*"])
    stiffness: JointValue | None = None  # kp [N·m/rad]
    damping: JointValue | None = None  # kd [N·m·s/rad]
    effort_limit: JointValue | None = None  # [N·m]
    velocity_limit: JointValue | None = None  # [rad/s], used by limit rewards (MuJoCo has no joint speed limit)
    armature: JointValue | None = None  # [kg·m²]
    friction: JointValue | None = None  # joint dry friction [N·m]


NON_NEGATIVE_FIELDS = ("stiffness", "damping", "armature", "friction")
POSITIVE_FIELDS = ("effort_limit", "velocity_limit", "saturation_effort")
"""A limit of 0 leaves a joint no torque range (MuJoCo refuses it) or divides (the DC motor's speed line)."""


def check_actuator_values(cfg: ImplicitActuatorCfg) -> None:
    """Raise ValueError naming the field (and the joint regex of a per-joint value) outside its domain: gains,
    armature and friction >= 0 (a negative armature makes the mass matrix indefinite), limits > 0."""
    for name in NON_NEGATIVE_FIELDS + POSITIVE_FIELDS:
        value = getattr(cfg, name, None)
        items = value.items() if isinstance(value, dict) else [] if value is None else [(None, value)]
        for key, v in items:
            ok = v > 0 if name in POSITIVE_FIELDS else v >= 0
            if not ok:
                where = name if key is None else f"{name}[{key!r}]"
                raise ValueError(f"{where} must be {'positive' if name in POSITIVE_FIELDS else '>= 0'}, got {v}")
