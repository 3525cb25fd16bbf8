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
