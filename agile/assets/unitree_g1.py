"""Unitree G1 29-DoF, Menagerie `unitree_g1/g1_mjx.xml` (primitive colliders), with AGILE parameters."""

from __future__ import annotations

import dataclasses

from agile.actuators import (DelayedDCMotorCfg, DelayedImplicitActuatorCfg, ImplicitActuatorCfg, action_scale,
                             armature_gains)
from agile.assets.files import asset_file
from agile.sim import ArticulationCfg

LEG_JOINTS = ".*_hip_.*_joint|.*_knee_joint"
FEET_JOINTS = ".*_ankle_.*_joint"
WAIST_JOINTS = "waist_.*_joint"
ARM_JOINTS = ".*_shoulder_.*_joint|.*_elbow_joint|.*_wrist_.*_joint"
LOWER_BODY_JOINTS = [".*_hip_.*_joint", ".*_knee_joint", ".*_ankle_.*_joint"]
"""The 12 leg joints."""

# AGILE's BeyondMimic standing pose (its `G1_29DOF_BeyondMimic` robot). AGILE's velocity task uses another
# robot config that stands straighter (hip -0.1, knee 0.3, ankle -0.2 rad, arms at 0, z 0.9 m); the shipped G1
# policy was trained on this one (docs/agile_differences.md).
INIT_JOINT_POS = {
    ".*_hip_pitch_joint": -0.312, ".*_knee_joint": 0.669, ".*_ankle_pitch_joint": -0.363,
    ".*_elbow_joint": 0.6, "left_shoulder_roll_joint": 0.2, "right_shoulder_roll_joint": -0.2,
    ".*_shoulder_pitch_joint": 0.2,
}
INIT_HEIGHT_M = 0.76

# AGILE `G1_29DOF_DELAYED_DC_MOTOR` gains and limits (reference section 4), per group.
ARMATURE = 0.02
LEGS = dict(effort_limit={".*_hip_.*": 88.0, ".*_knee_joint": 139.0},
            velocity_limit={".*_hip_.*": 32.0, ".*_knee_joint": 20.0},
            stiffness={".*_hip_.*": 100.0, ".*_knee_joint": 200.0},
            damping={".*_hip_.*": 2.5, ".*_knee_joint": 5.0})
FEET = dict(effort_limit=50.0, velocity_limit=37.0, stiffness=20.0,
            damping={".*_ankle_pitch_joint": 0.2, ".*_ankle_roll_joint": 0.1})
WAIST = dict(effort_limit={"waist_yaw_joint": 88.0, "waist_(roll|pitch)_joint": 50.0},
             velocity_limit={"waist_yaw_joint": 32.0, "waist_(roll|pitch)_joint": 37.0},
             stiffness=300.0, damping=5.0)
ARMS = dict(effort_limit={".*_shoulder_.*|.*_elbow_joint|.*_wrist_roll_joint": 25.0, ".*_wrist_(pitch|yaw)_joint": 5.0},
            velocity_limit={".*_shoulder_.*|.*_elbow_joint|.*_wrist_roll_joint": 37.0,
                            ".*_wrist_(pitch|yaw)_joint": 22.0},
            stiffness={".*_shoulder_pitch_joint": 90.0, ".*_shoulder_roll_joint": 60.0,
                       ".*_shoulder_yaw_joint": 20.0, ".*_elbow_joint": 60.0, ".*_wrist_.*_joint": 4.0},
            damping={".*_shoulder_pitch_joint": 2.0, ".*_shoulder_roll_joint": 1.0, ".*_shoulder_yaw_joint": 0.4,
                     ".*_elbow_joint": 1.0, ".*_wrist_.*_joint": 0.2})


MAX_DELAY_PHYSICS_STEPS = 4  # 0-20 ms at 200 Hz
SOFT_JOINT_POS_LIMIT_FACTOR = 0.9  # Isaac Lab's G1 configs: dof_pos_limits penalises the outer 5% of each range


def g1_delayed_dc_motor_actuators() -> dict:
    """AGILE `G1_29DOF_DELAYED_DC_MOTOR`: legs, feet and waist delayed 0-4 physics steps, arms undelayed."""
    def group(expr, params, saturation, max_delay):
        return DelayedDCMotorCfg(joint_names_expr=[expr], armature=ARMATURE, saturation_effort=saturation,
                                 min_delay=0, max_delay=max_delay, **params)

    return {"legs": group(LEG_JOINTS, LEGS, 180.0, MAX_DELAY_PHYSICS_STEPS),
            "feet": group(FEET_JOINTS, FEET, 80.0, MAX_DELAY_PHYSICS_STEPS),
            "waist": group(WAIST_JOINTS, WAIST, 120.0, MAX_DELAY_PHYSICS_STEPS),
            "arms": group(ARM_JOINTS, ARMS, 40.0, 0)}


# AGILE `G1_29DOF_HEIGHT_TRACKING` (V1.3, agile_tasks.md 2.5): the DC-motor G1 made softer for sitting down and
# lying relaxed. The reference lists knee kp 100 / kd 2.5, waist 100 / 2.5, arms 20 / 0.5, saturation 130 and
# friction 0.01 without naming the groups of the last two: here the leg saturation (180 N·m) becomes 130 and every
# joint gets 0.01 N·m of dry friction.
HEIGHT_TRACKING_KNEE_GAINS = dict(stiffness=100.0, damping=2.5)
HEIGHT_TRACKING_WAIST_GAINS = dict(stiffness=100.0, damping=2.5)
HEIGHT_TRACKING_ARM_GAINS = dict(stiffness=20.0, damping=0.5)
HEIGHT_TRACKING_LEG_SATURATION_NM = 130.0
HEIGHT_TRACKING_JOINT_FRICTION_NM = 0.01


def g1_height_tracking_actuators() -> dict:
    """The delayed DC-motor set with AGILE's softer height-tracking gains (see the constants above)."""
    groups = g1_delayed_dc_motor_actuators()
    legs = groups["legs"]
    legs.stiffness = {**legs.stiffness, ".*_knee_joint": HEIGHT_TRACKING_KNEE_GAINS["stiffness"]}
    legs.damping = {**legs.damping, ".*_knee_joint": HEIGHT_TRACKING_KNEE_GAINS["damping"]}
    legs.saturation_effort = HEIGHT_TRACKING_LEG_SATURATION_NM
    groups["waist"] = dataclasses.replace(groups["waist"], **HEIGHT_TRACKING_WAIST_GAINS)
    groups["arms"] = dataclasses.replace(groups["arms"], **HEIGHT_TRACKING_ARM_GAINS)
    return {name: dataclasses.replace(group, friction=HEIGHT_TRACKING_JOINT_FRICTION_NM)
            for name, group in groups.items()}


# Motor reflected inertias [kg·m²] (BeyondMimic), gains from armature: kp = J·ωn², kd = 2ζ·J·ωn
ARMATURE_5020 = 0.003609725
ARMATURE_7520_14 = 0.010177520
ARMATURE_7520_22 = 0.025101925
ARMATURE_4010 = 0.00425
ARMATURE_BY_GROUP = {  # joint regex: (armature, effort limit [N·m], velocity limit [rad/s])
    ".*_hip_(pitch|yaw)_joint": (ARMATURE_7520_14, 88.0, 32.0),
    ".*_hip_roll_joint|.*_knee_joint": (ARMATURE_7520_22, 139.0, 20.0),
    ".*_ankle_.*_joint": (2 * ARMATURE_5020, 50.0, 37.0),
    "waist_(roll|pitch)_joint": (2 * ARMATURE_5020, 50.0, 37.0),
    "waist_yaw_joint": (ARMATURE_7520_14, 88.0, 32.0),
    ".*_shoulder_.*_joint|.*_elbow_joint|.*_wrist_roll_joint": (ARMATURE_5020, 25.0, 37.0),
    ".*_wrist_(pitch|yaw)_joint": (ARMATURE_4010, 5.0, 22.0),
}
ARMATURE_GAINS = {expr: armature_gains(j) for expr, (j, _, _) in ARMATURE_BY_GROUP.items()}
ACTION_SCALE = {expr: action_scale(effort, ARMATURE_GAINS[expr][0])
                for expr, (_, effort, _) in ARMATURE_BY_GROUP.items()}
"""AGILE `G1_29DOF_ACTION_SCALE`: 0.25·effort/kp per joint group."""


def g1_armature_actuators() -> dict:
    """AGILE `G1_29DOF` (FEB26): armature-derived gains; legs and feet delayed implicit PD (0-4 physics
    steps), waist and arms implicit PD."""
    def group(cls, exprs, **extra):
        pick = {e: v for e, v in ARMATURE_BY_GROUP.items() if e in exprs}
        return cls(joint_names_expr=list(pick), stiffness={e: ARMATURE_GAINS[e][0] for e in pick},
                   damping={e: ARMATURE_GAINS[e][1] for e in pick}, armature={e: v[0] for e, v in pick.items()},
                   effort_limit={e: v[1] for e, v in pick.items()}, velocity_limit={e: v[2] for e, v in pick.items()},
                   **extra)

    legs_and_feet = [".*_hip_(pitch|yaw)_joint", ".*_hip_roll_joint|.*_knee_joint", ".*_ankle_.*_joint"]
    waist_and_arms = ["waist_(roll|pitch)_joint", "waist_yaw_joint",
                      ".*_shoulder_.*_joint|.*_elbow_joint|.*_wrist_roll_joint", ".*_wrist_(pitch|yaw)_joint"]
    return {"legs_feet": group(DelayedImplicitActuatorCfg, legs_and_feet, min_delay=0,
                               max_delay=MAX_DELAY_PHYSICS_STEPS),
            "waist_arms": group(ImplicitActuatorCfg, waist_and_arms)}


def g1_beyondmimic_actuators() -> dict:
    """AGILE `G1_29DOF_BeyondMimic` (motion tracking): the armature-derived gains of `g1_armature_actuators` on the
    solver's implicit PD for every joint, with no delay (AGILE sets min_delay = max_delay = 0)."""
    groups = ("hip_pitch_yaw", "hip_roll_knee", "ankles", "waist_roll_pitch", "waist_yaw", "arms", "wrists")
    return {group: ImplicitActuatorCfg(joint_names_expr=[expr], stiffness=ARMATURE_GAINS[expr][0],
                                       damping=ARMATURE_GAINS[expr][1], armature=armature, effort_limit=effort,
                                       velocity_limit=velocity)
            for group, (expr, (armature, effort, velocity)) in zip(groups, ARMATURE_BY_GROUP.items(), strict=True)}


def g1_implicit_actuators() -> dict:
    """The DC-motor gains handed to the solver's implicit PD."""
    return {"legs": ImplicitActuatorCfg(joint_names_expr=[LEG_JOINTS], armature=ARMATURE, **LEGS),
            "feet": ImplicitActuatorCfg(joint_names_expr=[FEET_JOINTS], armature=ARMATURE, **FEET),
            "waist": ImplicitActuatorCfg(joint_names_expr=[WAIST_JOINTS], armature=ARMATURE, **WAIST),
            "arms": ImplicitActuatorCfg(joint_names_expr=[ARM_JOINTS], armature=ARMATURE, **ARMS)}


def g1_robot_cfg(actuators: dict | None = None) -> ArticulationCfg:
    """G1 29-DoF with `actuators` (the groups of one of the `g1_*_actuators()` above; default the delayed DC motors of
    `g1_delayed_dc_motor_actuators()`); collider geoms switched on (see ArticulationCfg)."""
    return ArticulationCfg(
        model_file=asset_file("unitree_g1/g1_mjx.xml"),
        init_pos_m=(0.0, 0.0, INIT_HEIGHT_M),
        init_joint_pos=dict(INIT_JOINT_POS),
        enable_all_colliders=True,
        mjcf_collider_classes=("collision", "foot_box", "foot_capsule"),
        actuators=g1_delayed_dc_motor_actuators() if actuators is None else actuators,
        soft_joint_pos_limit_factor=SOFT_JOINT_POS_LIMIT_FACTOR,
    )
