"""Unitree G1 29-DoF, Menagerie `unitree_g1/g1_mjx.xml` (primitive colliders), with AGILE parameters."""

from __future__ import annotations

from agile.actuators import ImplicitActuatorCfg
from agile.assets.files import asset_file
from agile.sim import RobotCfg

LEG_JOINTS = ".*_hip_.*_joint|.*_knee_joint"
FEET_JOINTS = ".*_ankle_.*_joint"
WAIST_JOINTS = "waist_.*_joint"
ARM_JOINTS = ".*_shoulder_.*_joint|.*_elbow_joint|.*_wrist_.*_joint"
LOWER_BODY_JOINTS = [".*_hip_.*_joint", ".*_knee_joint", ".*_ankle_.*_joint"]
"""The 12 leg joints."""

# BeyondMimic standing pose used by AGILE.
INIT_JOINT_POS = {
    ".*_hip_pitch_joint": -0.312, ".*_knee_joint": 0.669, ".*_ankle_pitch_joint": -0.363,
    ".*_elbow_joint": 0.6, "left_shoulder_roll_joint": 0.2, "right_shoulder_roll_joint": -0.2,
    ".*_shoulder_pitch_joint": 0.2,
}
INIT_HEIGHT_M = 0.76

# AGILE `G1_29DOF_DELAYED_DC_MOTOR` parameters (reference section 4), per group.
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


def g1_robot_cfg() -> RobotCfg:
    """G1 29-DoF with implicit PD at the AGILE gains; collider geoms switched on (see RobotCfg)."""
    return RobotCfg(
        model_file=asset_file("unitree_g1/g1_mjx.xml"),
        init_pos_m=(0.0, 0.0, INIT_HEIGHT_M),
        init_joint_pos=dict(INIT_JOINT_POS),
        enable_all_colliders=True,
        actuators={
            "legs": ImplicitActuatorCfg(joint_names_expr=[LEG_JOINTS], armature=ARMATURE, **LEGS),
            "feet": ImplicitActuatorCfg(joint_names_expr=[FEET_JOINTS], armature=ARMATURE, **FEET),
            "waist": ImplicitActuatorCfg(joint_names_expr=[WAIST_JOINTS], armature=ARMATURE, **WAIST),
            "arms": ImplicitActuatorCfg(joint_names_expr=[ARM_JOINTS], armature=ARMATURE, **ARMS),
        },
    )
