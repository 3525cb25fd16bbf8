"""Booster T1 (23 joints), Menagerie `booster_t1/t1.xml`, with the AGILE actuator parameters."""

from __future__ import annotations

from agile.actuators import DelayedDCMotorCfg, ImplicitActuatorCfg
from agile.assets.files import asset_file
from agile.sim import ArticulationCfg

LEG_JOINTS = ".*Hip.*|.*Knee.*|.*Ankle.*"
"""The 12 leg joints AGILE's T1 velocity policy controls."""
ARM_JOINTS = ".*Shoulder.*|.*Elbow.*"
HEAD_JOINTS = ".*Head.*"
WAIST_JOINTS = "Waist"

# Menagerie "home" keyframe: arms down, knees slightly bent (AGILE: shoulder roll ∓1.3, elbow yaw ∓0.3,
# z 0.71 m; the shipped T1 policy was trained on this one, docs/agile_differences.md).
INIT_JOINT_POS = {
    "Left_Shoulder_Roll": -1.4, "Right_Shoulder_Roll": 1.4,
    "Left_Elbow_Yaw": -0.4, "Right_Elbow_Yaw": 0.4,
    ".*_Hip_Pitch": -0.2, ".*_Knee_Pitch": 0.4, ".*_Ankle_Pitch": -0.2,
}
INIT_HEIGHT_M = 0.68

# AGILE T1 gains (reference table, section 4): kp [N·m/rad], kd [N·m·s/rad], limits [N·m], [rad/s]
T1_STIFFNESS = {HEAD_JOINTS: 20.0, ARM_JOINTS: 20.0, WAIST_JOINTS: 100.0, ".*Hip.*": 100.0, ".*Knee.*": 100.0,
                ".*Ankle.*": 20.0}
T1_DAMPING = {HEAD_JOINTS: 0.2, ARM_JOINTS: 0.5, WAIST_JOINTS: 2.5, ".*Hip.*": 2.5, ".*Knee.*": 2.5,
              ".*Ankle.*": 1.0}
T1_EFFORT_LIMIT = {HEAD_JOINTS: 7.0, ARM_JOINTS: 18.0, WAIST_JOINTS: 30.0, ".*Hip_Pitch": 45.0,
                   ".*Hip_Roll|.*Hip_Yaw": 30.0, ".*Knee.*": 60.0, ".*Ankle_Pitch": 24.0, ".*Ankle_Roll": 15.0}
T1_VELOCITY_LIMIT = {HEAD_JOINTS: 30.0, ARM_JOINTS: 30.0, WAIST_JOINTS: 32.0, ".*Hip.*": 32.0, ".*Knee.*": 20.0,
                     ".*Ankle.*": 32.0}
T1_ARMATURE = 0.02
T1_FRICTION = 0.01
T1_SATURATION_EFFORT = 130.0  # [N·m]
T1_MAX_DELAY_PHYSICS_STEPS = 8  # 0-40 ms at 200 Hz
# AGILE `T1_DELAYED_DC_CFG.soft_joint_pos_limit_factor`: the knee's soft lower limit is 0.117 rad, so a policy
# standing on straight knees pressed into the hard stop (q = 0) pays dof_pos_limits; without it one does
T1_SOFT_JOINT_POS_LIMIT_FACTOR = 0.9

T1_GAINS = dict(joint_names_expr=[".*"], stiffness=T1_STIFFNESS, damping=T1_DAMPING, effort_limit=T1_EFFORT_LIMIT,
                velocity_limit=T1_VELOCITY_LIMIT, armature=T1_ARMATURE, friction=T1_FRICTION)

def t1_delayed_dc_motor_actuators() -> dict:
    """AGILE `T1_DELAYED_DC_CFG`: one group, delayed DC motors."""
    return {"all": DelayedDCMotorCfg(**T1_GAINS, saturation_effort=T1_SATURATION_EFFORT, min_delay=0,
                                     max_delay=T1_MAX_DELAY_PHYSICS_STEPS)}


def t1_implicit_actuators() -> dict:
    """The same gains handed to the solver's implicit PD."""
    return {"all": ImplicitActuatorCfg(**T1_GAINS)}


def t1_robot_cfg(actuators: dict | None = None) -> ArticulationCfg:
    """T1 with `actuators` (default `t1_delayed_dc_motor_actuators()`)."""
    return ArticulationCfg(
        model_file=asset_file("booster_t1/t1.xml"),
        init_pos_m=(0.0, 0.0, INIT_HEIGHT_M),
        init_joint_pos=dict(INIT_JOINT_POS),
        actuators=t1_delayed_dc_motor_actuators() if actuators is None else actuators,
        soft_joint_pos_limit_factor=T1_SOFT_JOINT_POS_LIMIT_FACTOR,
    )
