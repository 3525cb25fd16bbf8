"""MotionTracking-G1-v0 (= Tracking-Flat-G1-v0): Unitree G1 dances, tracking a reference motion with all 29 joints
from a single-frame observation (AGILE `tracking/g1/flat_env_cfg.py`, BeyondMimic).

Each episode starts at a frame of the motion drawn by adaptive sampling (segments where the policy fails are
drawn more often) with the robot placed in the reference state there; the rewards compare the torso (anchor) in
the world frame and 14 bodies relative to it with the reference. The motion file is a field:
`env.commands.motion.motion_file=<path or shipped name>` on any script's command line (docs/motion_tracking.md).
"""

from __future__ import annotations

from agile.assets.unitree_g1 import ACTION_SCALE, g1_beyondmimic_actuators, g1_robot_cfg
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import DoneTerm, EventTerm, ObsGroup, ObsTerm, RewTerm, SceneEntityCfg, Unoise
from agile.sim.scene_cfg import ContactSensorCfg, SceneCfg
from agile.tasks.motion_tracking import mdp
from agile.tasks.velocity.velocity_common import velocity_sim_cfg
from agile.utils.config import configclass

MOTION = "motion"
CONTACT_SENSOR = "contact_forces"
ANCHOR_BODY = "torso_link"
TRACKED_BODIES = [
    "pelvis", "left_hip_roll_link", "left_knee_link", "left_ankle_roll_link", "right_hip_roll_link",
    "right_knee_link", "right_ankle_roll_link", "torso_link", "left_shoulder_roll_link", "left_elbow_link",
    "left_wrist_yaw_link", "right_shoulder_roll_link", "right_elbow_link", "right_wrist_yaw_link",
]
END_EFFECTORS = ["left_ankle_roll_link", "right_ankle_roll_link", "left_wrist_yaw_link", "right_wrist_yaw_link"]
NOT_END_EFFECTORS = "^(?!left_ankle_roll_link$)(?!right_ankle_roll_link$)(?!left_wrist_yaw_link$)(?!right_wrist_yaw_link$).+$"
"""Every body but the feet and hands: the bodies that should not touch anything."""
PUSH_VELOCITY_RANGE = {"x": (-0.5, 0.5), "y": (-0.5, 0.5), "z": (-0.2, 0.2),
                       "roll": (-0.52, 0.52), "pitch": (-0.52, 0.52), "yaw": (-0.78, 0.78)}
"""Pushes [m/s, rad/s], also the spread of the root velocity at an episode start."""
ROBOT_FRICTION_RANGE = (0.3, 1.2)

# -- scene: the robot with BeyondMimic's actuators on flat ground, contact forces on every body
SCENE = SceneCfg(
    entities={"robot": g1_robot_cfg(g1_beyondmimic_actuators())},
    terrain=None, env_spacing_m=2.5,
    # a MuJoCo contact takes the larger friction of its two geoms: ground at the bottom of the robot's range
    ground_friction=ROBOT_FRICTION_RANGE[0],
    contact_sensors={CONTACT_SENSOR: ContactSensorCfg(entity="robot", body_names=".*", history_length=3,
                                                      track_air_time=False)})


@configclass
class CommandsCfg:
    motion = mdp.MotionCommandCfg(
        motion_file="g1_squat_arm_swing", anchor_body_name=ANCHOR_BODY, body_names=list(TRACKED_BODIES),
        pose_range={"x": (-0.05, 0.05), "y": (-0.05, 0.05), "z": (-0.01, 0.01),
                    "roll": (-0.1, 0.1), "pitch": (-0.1, 0.1), "yaw": (-0.2, 0.2)},
        velocity_range=dict(PUSH_VELOCITY_RANGE), joint_position_range=(-0.2, 0.2),
        adaptive_uniform_ratio=0.8)


@configclass
class ActionsCfg:
    joint_pos = mdp.JointPositionActionCfg(joint_names=[".*"], scale=dict(ACTION_SCALE), use_default_offset=True)


@configclass
class PolicyObsCfg(ObsGroup):
    """No state estimate: the reference, the anchor's orientation error, gyro and joints, noisy."""

    enable_corruption = True
    command = ObsTerm(func=mdp.generated_commands, params={"command_name": MOTION})
    motion_anchor_ori_b = ObsTerm(func=mdp.motion_anchor_ori_b, params={"command_name": MOTION},
                                  noise=Unoise(-0.05, 0.05))
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel, noise=Unoise(-0.2, 0.2))
    joint_pos = ObsTerm(func=mdp.joint_pos_rel, noise=Unoise(-0.01, 0.01))
    joint_vel = ObsTerm(func=mdp.joint_vel_rel, noise=Unoise(-0.5, 0.5))
    actions = ObsTerm(func=mdp.last_action)


@configclass
class CriticObsCfg(ObsGroup):
    """Noise-free, with the anchor's position error, the tracked bodies and the base velocity."""

    command = ObsTerm(func=mdp.generated_commands, params={"command_name": MOTION})
    motion_anchor_pos_b = ObsTerm(func=mdp.motion_anchor_pos_b, params={"command_name": MOTION})
    motion_anchor_ori_b = ObsTerm(func=mdp.motion_anchor_ori_b, params={"command_name": MOTION})
    body_pos = ObsTerm(func=mdp.robot_body_pos_b, params={"command_name": MOTION})
    body_ori = ObsTerm(func=mdp.robot_body_ori_b, params={"command_name": MOTION})
    base_lin_vel = ObsTerm(func=mdp.base_lin_vel)
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel)
    joint_pos = ObsTerm(func=mdp.joint_pos_rel)
    joint_vel = ObsTerm(func=mdp.joint_vel_rel)
    actions = ObsTerm(func=mdp.last_action)


@configclass
class ObservationsCfg:
    policy = PolicyObsCfg()
    critic = CriticObsCfg()


@configclass
class RewardsCfg:
    # -- tracking (std in m, rad, m/s, rad/s)
    motion_global_anchor_position_error_exp = RewTerm(
        func=mdp.motion_global_anchor_position_error_exp, weight=0.5, params={"command_name": MOTION, "std": 0.3})
    motion_global_anchor_orientation_error_exp = RewTerm(
        func=mdp.motion_global_anchor_orientation_error_exp, weight=0.5, params={"command_name": MOTION, "std": 0.4})
    wb_motion_relative_body_position_error_exp = RewTerm(
        func=mdp.motion_relative_body_position_error_exp, weight=1.0, params={"command_name": MOTION, "std": 0.3})
    wb_motion_relative_body_orientation_error_exp = RewTerm(
        func=mdp.motion_relative_body_orientation_error_exp, weight=1.0, params={"command_name": MOTION, "std": 0.4})
    wb_motion_global_body_linear_velocity_error_exp = RewTerm(
        func=mdp.motion_global_body_linear_velocity_error_exp, weight=1.0,
        params={"command_name": MOTION, "std": 1.0})
    wb_motion_global_body_angular_velocity_error_exp = RewTerm(
        func=mdp.motion_global_body_angular_velocity_error_exp, weight=1.0,
        params={"command_name": MOTION, "std": 3.14})
    # -- regularisation
    action_rate_l2 = RewTerm(func=mdp.action_rate_l2, weight=-0.1)
    joint_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-10.0)
    joint_vel_limits = RewTerm(func=mdp.joint_vel_limits, weight=-1.0, params={"soft_ratio": 0.9})
    joint_vel_l2 = RewTerm(func=mdp.joint_vel_l2, weight=-1.0e-3)
    applied_torque_limits = RewTerm(func=mdp.applied_torque_limits, weight=-0.01)
    joint_acc_l2 = RewTerm(func=mdp.joint_acc_l2, weight=-2.5e-7)
    undesired_contacts = RewTerm(func=mdp.undesired_contacts, weight=-0.1,
                                 params={"force_threshold_n": 1.0,
                                         "sensor_cfg": SceneEntityCfg(CONTACT_SENSOR, body_names=NOT_END_EFFECTORS)})


@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)
    anchor_pos = DoneTerm(func=mdp.bad_anchor_pos_z_only, params={"command_name": MOTION, "threshold_m": 0.25})
    anchor_ori = DoneTerm(func=mdp.bad_anchor_ori, params={"command_name": MOTION, "threshold": 0.8})
    ee_body_pos = DoneTerm(func=mdp.bad_motion_body_pos_z_only,
                           params={"command_name": MOTION, "threshold_m": 0.25, "body_names": END_EFFECTORS})


@configclass
class EventsCfg:
    """Domain randomisation at startup (each world draws its robot once) and disturbances; no reset events: the
    motion command places the robot at each episode start."""

    # -- startup
    physics_material = EventTerm(
        func=mdp.randomize_rigid_body_material, mode="startup",
        params={"static_friction_range": (0.3, 1.6), "dynamic_friction_range": ROBOT_FRICTION_RANGE,
                "restitution_range": (0.0, 0.5), "num_buckets": 64})
    add_joint_default_pos = EventTerm(func=mdp.randomize_joint_default_pos, mode="startup",
                                      params={"pos_distribution_params": (-0.01, 0.01)})
    base_com = EventTerm(func=mdp.randomize_rigid_body_com, mode="startup",
                         params={"com_range": {"x": (-0.025, 0.025), "y": (-0.05, 0.05), "z": (-0.05, 0.05)},
                                 "asset_cfg": SceneEntityCfg("robot", body_names=ANCHOR_BODY)})
    actuator_gains = EventTerm(
        func=mdp.randomize_actuator_gains, mode="startup",
        params={"stiffness_distribution_params": (0.9, 1.1), "damping_distribution_params": (0.8, 2.0),
                "operation": "scale"})
    joint_friction = EventTerm(func=mdp.randomize_joint_parameters, mode="startup",
                               params={"friction_distribution_params": (0.0, 0.005), "operation": "abs"})
    joint_armature = EventTerm(func=mdp.randomize_joint_parameters, mode="startup",
                               params={"armature_distribution_params": (0.0, 2.0), "operation": "scale"})
    body_mass = EventTerm(func=mdp.randomize_rigid_body_mass, mode="startup",
                          params={"mass_distribution_params": (0.95, 1.05), "operation": "scale"})
    # -- interval
    push_robot = EventTerm(func=mdp.push_by_setting_velocity, mode="interval", interval_range_s=(0.0, 8.0),
                           params={"velocity_range": dict(PUSH_VELOCITY_RANGE)})
    torso_external_wrench = EventTerm(
        func=mdp.apply_external_force_torque, mode="interval", interval_range_s=(0.0, 10.0),
        params={"force_range": (-5.0, 5.0), "torque_range": (-2.0, 2.0),
                "asset_cfg": SceneEntityCfg("robot", body_names=ANCHOR_BODY)})
    wrists_external_wrench = EventTerm(
        func=mdp.apply_external_force_torque, mode="interval", interval_range_s=(0.0, 10.0),
        params={"force_range": (-5.0, 5.0), "torque_range": (-0.5, 0.5),
                "asset_cfg": SceneEntityCfg("robot", body_names=["left_wrist_yaw_link", "right_wrist_yaw_link"])})


@configclass
class G1MotionTrackingEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 4096
    decimation = 4  # 50 Hz policy, the motion files' frame rate
    episode_length_s = 10.0
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=128)
    commands = CommandsCfg()
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RewardsCfg()
    terminations = TerminationsCfg()
    events = EventsCfg()
    curriculum = None  # AGILE: full difficulty from the start
