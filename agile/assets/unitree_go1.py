"""Unitree Go1 quadruped (12 joints), MuJoCo Menagerie `unitree_go1/go1.xml` shipped in agile/data/robots (BSD-3,
its LICENSE beside it), with the motor parameters mjlab trains the same model with.

The file's own joint damping (2 N·m·s/rad, abduction 1) and dry friction (0.2 N·m) stay: they are the model's
passive joint losses, on top of the PD gains below. Its feet are spheres (r 2.3 cm) at the bottom of the calf
bodies, so the feet bodies are the calves."""

from __future__ import annotations

from pathlib import Path

import agile.data.robots
from agile.actuators import ImplicitActuatorCfg, action_scale, armature_gains
from agile.sim import ArticulationCfg

GO1_MODEL_FILE = str(Path(agile.data.robots.__file__).parent / "unitree_go1" / "go1.xml")
GO1_COLLIDER_CLASSES = ("collision",)
"""Newton imports every geom of the file's collision classes (`agile robot check` counts them all)."""

LEG_JOINTS = ".*_hip_joint|.*_thigh_joint|.*_calf_joint"
"""All 12 joints: abduction (hip, about x), hip (thigh, about y), knee (calf, about y) of each leg."""
HIP_THIGH_JOINTS = ".*_hip_joint|.*_thigh_joint"
KNEE_JOINTS = ".*_calf_joint"
BASE_BODY = "trunk"
FOOT_BODIES = ["FL_calf", "FR_calf", "RL_calf", "RR_calf"]
"""Left-right pairs next to each other (FL, FR, then RL, RR): the order feet terms read them in."""
THIGH_BODIES = ["FL_thigh", "FR_thigh", "RL_thigh", "RR_thigh"]

# mjlab `go1_constants.INIT_STATE`: the Menagerie "home" crouch (thigh 0.9, calf -1.8 rad) with the legs splayed
# 0.1 rad outwards. mjlab spawns it at 0.278 m; `agile robot check` puts the feet of this model on flat ground with
# the trunk at 0.2945 m, so it spawns 5 mm above (at 0.278 m its feet would start 1.6 cm inside the ground).
INIT_JOINT_POS = {".*_thigh_joint": 0.9, ".*_calf_joint": -1.8, ".*R_hip_joint": 0.1, ".*L_hip_joint": -0.1}
INIT_HEIGHT_M = 0.30

# Motors (mjlab, from Unitree's URDF): rotor inertia about its axis and the gearboxes, reflected at the joint as
# J·N²; effort and speed limits of the hip and knee motors.
ROTOR_INERTIA_KGM2 = 0.000111842
HIP_GEAR_RATIO = 6.0
KNEE_GEAR_RATIO = 9.0
HIP_ARMATURE_KGM2 = ROTOR_INERTIA_KGM2 * HIP_GEAR_RATIO ** 2
KNEE_ARMATURE_KGM2 = ROTOR_INERTIA_KGM2 * KNEE_GEAR_RATIO ** 2
HIP_EFFORT_LIMIT_NM, KNEE_EFFORT_LIMIT_NM = 23.7, 35.55
HIP_VELOCITY_LIMIT_RADPS, KNEE_VELOCITY_LIMIT_RADPS = 30.1, 20.06
MOTORS = {  # joint regex: (armature, effort limit, velocity limit)
    HIP_THIGH_JOINTS: (HIP_ARMATURE_KGM2, HIP_EFFORT_LIMIT_NM, HIP_VELOCITY_LIMIT_RADPS),
    KNEE_JOINTS: (KNEE_ARMATURE_KGM2, KNEE_EFFORT_LIMIT_NM, KNEE_VELOCITY_LIMIT_RADPS),
}
GAINS = {expr: armature_gains(armature) for expr, (armature, _, _) in MOTORS.items()}
"""(kp, kd) per group from the armature: 10 Hz natural frequency, damping ratio 2 (as the G1's armature gains)."""
ACTION_SCALE = {expr: action_scale(effort, GAINS[expr][0]) for expr, (_, effort, _) in MOTORS.items()}
"""0.25·effort/kp per group (mjlab `GO1_ACTION_SCALE`): a unit action asks for a quarter of the effort limit."""
SOFT_JOINT_POS_LIMIT_FACTOR = 0.9  # mjlab's Go1


def go1_implicit_actuators() -> dict:
    """mjlab's Go1: the solver's implicit PD on every joint, two motor groups."""
    return {group: ImplicitActuatorCfg(joint_names_expr=[expr], stiffness=GAINS[expr][0], damping=GAINS[expr][1],
                                       armature=armature, effort_limit=effort, velocity_limit=velocity)
            for group, (expr, (armature, effort, velocity)) in zip(("hips_thighs", "knees"), MOTORS.items(),
                                                                    strict=True)}


def go1_robot_cfg(actuators: dict | None = None) -> ArticulationCfg:
    """The Go1 with `actuators` (default `go1_implicit_actuators()`), standing in its crouch."""
    return ArticulationCfg(
        model_file=GO1_MODEL_FILE,
        init_pos_m=(0.0, 0.0, INIT_HEIGHT_M),
        init_joint_pos=dict(INIT_JOINT_POS),
        mjcf_collider_classes=GO1_COLLIDER_CLASSES,
        # the file's 1 mm: on flat ground Newton zeroes it with a warning per collider (42), the same 0 on any ground
        collider_margin_m=0.0,
        actuators=go1_implicit_actuators() if actuators is None else actuators,
        soft_joint_pos_limit_factor=SOFT_JOINT_POS_LIMIT_FACTOR,
    )
