"""Unitree G1 29-DoF with Dex3-1 hands (7 joints each), Menagerie `unitree_g1/g1_with_hands.xml`.

The legs, waist and arms have the actuators the frozen lower-body policy was trained with (the Velocity-Height-G1
teacher: `unitree_g1._armature_set`); the fingers are soft PD joints. The file's collision geoms are the links'
meshes (convex hulls in the solver) and spheres under the feet: the fingers and palm collide, so they can grasp.
"""

from __future__ import annotations

from agile.actuators import ImplicitActuatorCfg
from agile.assets.files import asset_file
from agile.assets.unitree_g1 import (INIT_HEIGHT_M, INIT_JOINT_POS, SOFT_JOINT_POS_LIMIT_FACTOR,
                                    g1_armature_actuators)
from agile.sim import ArticulationCfg

RIGHT_ARM_JOINTS = ["right_shoulder_.*_joint", "right_elbow_joint", "right_wrist_.*_joint"]
RIGHT_HAND_JOINTS = ["right_hand_.*_joint"]
WAIST_JOINTS = ["waist_.*_joint"]
UPPER_BODY_JOINTS = [*WAIST_JOINTS, *RIGHT_ARM_JOINTS, *RIGHT_HAND_JOINTS]
"""The joints the pick-and-place policy drives and the trajectories give (3 waist + 7 arm + 7 hand = 17)."""
HAND_JOINTS = ".*_hand_.*_joint"
PALM_BODY = "right_wrist_yaw_link"
GRASP_POINT_M = (0.105, 0.075, -0.02)
"""The right hand's grasp point in the wrist-yaw link's frame: where the held cube's centre sits in the pick-and-place
reference's pinch (`make_pick_place_trajectories.py` solves every frame for it): its face 2 cm off the palm's surface,
between the thumb (x 0.07) and the curled middle fingertip (x 0.14), 2 cm below the hand's centre. The hand-object
reward (AGILE's, highest at distance 0) and observation use this point, so they peak when the cube is held. With
the palm's centre (0.11, 0.03, 0), 4.9 cm from the held cube's centre, the reward paid a grasp 0.79 and a palm pressed
on the cube's top 0.96: a policy trained 600 iterations on it (H200) pressed its palm 2 cm from the cube's centre
in every episode and never lifted it (0.5 cm at most, CPU eval, 4 episodes)."""

HAND_GAINS = dict(stiffness=4.0, damping=0.2, effort_limit=2.45, velocity_limit=10.0, armature=0.001)
"""Dex3-1 finger motors: 2.45 N·m peak; soft, so that a closed hand squeezes rather than slams."""


def g1_with_hands_robot_cfg() -> ArticulationCfg:
    """The G1 with hands standing at the G1's default pose, hands open."""
    actuators = g1_armature_actuators()
    actuators["hands"] = ImplicitActuatorCfg(joint_names_expr=[HAND_JOINTS], **HAND_GAINS)
    return ArticulationCfg(
        model_file=asset_file("unitree_g1/g1_with_hands.xml"),
        init_pos_m=(0.0, 0.0, INIT_HEIGHT_M),
        init_joint_pos=dict(INIT_JOINT_POS),
        mjcf_collider_classes=("collision", "foot"),
        actuators=actuators,
        soft_joint_pos_limit_factor=SOFT_JOINT_POS_LIMIT_FACTOR,
    )
