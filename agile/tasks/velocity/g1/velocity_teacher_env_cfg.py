"""Velocity-G1-Teacher-v0: Unitree G1 walks at commanded planar velocities up to 1 m/s, turning to a commanded
heading, controlling its 12 leg joints; a privileged teacher (it sees its base velocity; its critic also sees
the terrain under its feet).

AGILE V1.3 `locomotion/g1/velocity_env_cfg.py` (`G1LowerVelocityEnvCfg`): the Velocity-Height-G1 MDP with the
height held at 0.72 m, delayed DC motors, the harness removed over 50k env steps, pushes that grow while the
robot rarely falls (`pushing_curriculum`), and reward weights that ramp up from 50k env steps.
"""

from __future__ import annotations

import dataclasses
import math

from agile.assets.unitree_g1 import LOWER_BODY_JOINTS, g1_delayed_dc_motor_actuators
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import CurrTerm, DoneTerm, RewTerm, SceneEntityCfg, Unoise
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import (BASE_HEIGHT_SENSOR, CONTACT_SENSOR, VelocityEventsCfg,
                                                  random_upper_body_action_cfg, uniform_root_reset, velocity_events_cfg,
                                                  velocity_sim_cfg)
from agile.tasks.velocity.g1.velocity_g1_common import (COMMAND, FEET, FEET_CONTACT, FOOT_BODIES, LEGS,
                                                        STANDING_HEIGHT_M, TRUNK_CONTACT_BODIES, PrivilegedCriticObsCfg,
                                                        PrivilegedPolicyObsCfg, velocity_height_scene_cfg)
from agile.utils.config import configclass

TORSO = SceneEntityCfg("robot", body_names="torso_link")

# -- scene: as Velocity-Height-G1, with AGILE V1.3's delayed DC motors
SCENE = velocity_height_scene_cfg(g1_delayed_dc_motor_actuators())


@configclass
class CommandsCfg:
    base_velocity = mdp.UniformVelocityBaseHeightCommandCfg(
        height_sensor_name=BASE_HEIGHT_SENSOR,
        resampling_time_range_s=(5.0, 10.0), rel_standing_envs=0.2, ema_smoothing=0.5,
        heading_command=True, rel_heading_envs=1.0, heading_control_stiffness=0.5,
        default_height_m=STANDING_HEIGHT_M, min_walk_height_m=STANDING_HEIGHT_M,
        ranges=mdp.VelocityHeightRangesCfg(lin_vel_x=(-1.0, 1.0), lin_vel_y=(-1.0, 1.0), ang_vel_z=(-1.0, 1.0),
                                           base_height_m=(STANDING_HEIGHT_M, STANDING_HEIGHT_M)))


def random_arms_and_waist_yaw_action_cfg() -> mdp.RandomActionCfg:
    """AGILE: every joint but the legs and waist roll and pitch moves to random targets every 0.1-1.5 s while the
    robot stands, back to its default while it walks."""
    cfg = random_upper_body_action_cfg(excluded_joints=[*LOWER_BODY_JOINTS, "waist_roll_joint", "waist_pitch_joint"])
    return dataclasses.replace(cfg, sample_range_s=(0.1, 1.5), no_random_when_walking=True, command_name=COMMAND)


@configclass
class ActionsCfg:
    # AGILE clips the raw action to ±4 (the env's clip_actions below); the processed target is not clipped
    joint_pos = mdp.JointPositionActionCfg(joint_names=LOWER_BODY_JOINTS, scale=0.25, use_default_offset=True,
                                           clip=None)
    random_upper_body_pos = random_arms_and_waist_yaw_action_cfg()
    harness = mdp.HarnessActionCfg(body_name="pelvis", target_height_m=STANDING_HEIGHT_M, command_name=COMMAND,
                                   height_sensor=BASE_HEIGHT_SENSOR)


def low_noise_policy_obs_cfg() -> PrivilegedPolicyObsCfg:
    """AGILE V1.3's privileged policy group: the height teacher's terms with a tenth of its noise (gravity half)."""
    base = PrivilegedPolicyObsCfg()
    return dataclasses.replace(
        base, base_lin_vel=dataclasses.replace(base.base_lin_vel, noise=Unoise(-0.01, 0.01)),
        base_ang_vel=dataclasses.replace(base.base_ang_vel, noise=Unoise(-0.02, 0.02)),
        projected_gravity=dataclasses.replace(base.projected_gravity, noise=Unoise(-0.005, 0.005)),
        joint_pos=dataclasses.replace(base.joint_pos, noise=Unoise(-0.001, 0.001)),
        joint_vel=dataclasses.replace(base.joint_vel, noise=Unoise(-0.15, 0.15)))


@configclass
class ObservationsCfg:
    policy = low_noise_policy_obs_cfg()
    critic = PrivilegedCriticObsCfg()


@configclass
class RewardsCfg:
    # -- task
    termination_penalty = RewTerm(func=mdp.is_terminated, weight=-200.0)
    track_lin_vel_xy_exp = RewTerm(func=mdp.track_lin_vel_xy_yaw_frame_exp, weight=10.0,
                                   params={"command_name": COMMAND, "std": 0.5})
    track_ang_vel_z_exp = RewTerm(func=mdp.track_ang_vel_z_world_exp, weight=3.0,
                                  params={"command_name": COMMAND, "std": 0.5})
    track_base_height_exp_smooth = RewTerm(func=mdp.track_base_height_exp_smooth, weight=2.0,
                                           params={"command_name": COMMAND, "std": 0.05,
                                                   "sensor_name": BASE_HEIGHT_SENSOR})
    base_height_in_threshold = RewTerm(func=mdp.base_height_in_threshold, weight=0.1,
                                       params={"command_name": COMMAND, "threshold_m": 0.005,
                                               "sensor_name": BASE_HEIGHT_SENSOR})
    stand_with_both_feet_if_null_cmd = RewTerm(func=mdp.stand_with_both_feet_if_null_cmd, weight=10.0,
                                               params={"command_name": COMMAND, "threshold_n": 1.0,
                                                       "sensor_cfg": FEET_CONTACT})
    equal_foot_force_if_null_cmd = RewTerm(func=mdp.equal_foot_force_if_null_cmd, weight=1.0,
                                           params={"command_name": COMMAND, "sensor_cfg": FEET_CONTACT})
    no_undesired_base_velocity_exp = RewTerm(func=mdp.no_undesired_base_velocity_exp, weight=1.0,
                                             params={"std": 0.1})
    # -- joints and actions
    dof_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-1.0, params={"asset_cfg": LEGS})
    dof_vel_limits = RewTerm(func=mdp.joint_vel_limits, weight=-0.1, params={"asset_cfg": LEGS, "soft_ratio": 0.9})
    dof_vel_l2 = RewTerm(func=mdp.joint_vel_l2, weight=-1.0e-3, params={"asset_cfg": LEGS})
    torque_limits = RewTerm(func=mdp.applied_torque_limits, weight=-0.01, params={"asset_cfg": LEGS})
    dof_torques_l2 = RewTerm(func=mdp.joint_torques_l2, weight=-2.0e-5, params={"asset_cfg": LEGS})
    dof_acc_l2 = RewTerm(func=mdp.joint_acc_l2, weight=-2.5e-7, params={"asset_cfg": LEGS})
    action_rate = RewTerm(func=mdp.action_rate_l2, weight=-0.01)
    hip_pos_pen = RewTerm(func=mdp.joint_deviation_l2, weight=-1.0,
                          params={"asset_cfg": SceneEntityCfg("robot", joint_names=[".*_hip_roll_joint",
                                                                                    ".*_hip_yaw_joint"])})
    # -- style
    feet_slide = RewTerm(func=mdp.feet_slip, weight=-1.0, params={"sensor_cfg": FEET_CONTACT, "asset_cfg": FEET})
    jumping_penalty = RewTerm(func=mdp.jumping, weight=-10.0,
                              params={"sensor_cfg": FEET_CONTACT, "force_threshold_n": 0.1})
    impact_velocity = RewTerm(func=mdp.impact_velocity_l1, weight=-0.5,
                              params={"sensor_cfg": FEET_CONTACT, "force_threshold_n": 10.0})
    flat_orientation = RewTerm(func=mdp.flat_orientation_l2, weight=-1.0, params={"asset_cfg": TORSO})
    # AGILE names the torso, but its term reads the root's gravity (the pelvis) whatever the body
    flat_orientation_if_null_cmd = RewTerm(func=mdp.flat_orientation_if_null_cmd, weight=-4.0,
                                           params={"command_name": COMMAND})
    relax_if_null_cmd = RewTerm(func=mdp.relax_if_null_cmd, weight=-1.0e-3,
                                params={"command_name": COMMAND, "asset_cfg": LEGS})


@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)
    base_orientation = DoneTerm(func=mdp.bad_orientation,
                                params={"limit_angle_rad": math.radians(40.0), "asset_cfg": TORSO})
    illegal_contacts = DoneTerm(func=mdp.illegal_ground_contact,
                                params={"force_threshold_n": 50.0, "min_height_m": 0.4,
                                        "sensor_cfg": SceneEntityCfg(CONTACT_SENSOR, body_names=TRUNK_CONTACT_BODIES),
                                        "asset_cfg": TORSO})


def velocity_teacher_events_cfg() -> VelocityEventsCfg:
    """AGILE V1.3 `LocomotionEventCfg`: the velocity tasks' events with friction 0.4-1.5 / 0.4-0.8, restitution
    0-0.75, joint friction 0.001-0.005 N·m, armature ×0.8-1.2, torso +(-1..3) kg and COM shift, pushes on the
    torso (10 N / 5 N·m) and on the wrists and feet (5 N / 0.5 N·m); reset heights ±5 cm; pushes of 0.2 m/s and
    0.05 rad/s that `pushing_curriculum` grows."""
    return velocity_events_cfg(
        base_body="torso_link", base_mass_add_kg=(-1.0, 3.0),
        base_com_range_m={"x": (-0.15, 0.15), "y": (-0.05, 0.05), "z": (-0.15, 0.15)},
        extremity_bodies=["left_wrist_yaw_link", "right_wrist_yaw_link", *FOOT_BODIES],
        static_friction=(0.4, 1.5), dynamic_friction=(0.4, 0.8), restitution=(0.0, 0.75),
        joint_friction_nm=(0.001, 0.005), armature_scale=(0.8, 1.2), push_velocity=(0.2, 0.05),
        reset_base=uniform_root_reset(xy_range_m=2.5, z_range_m=0.05))


def ramp(reward_name: str, terminal_weight: float, start_step: int = 50_000, num_steps: int = 50_000) -> CurrTerm:
    """A reward weight moving linearly to `terminal_weight` over `num_steps` env steps from `start_step`."""
    return CurrTerm(func=mdp.update_reward_weight_step,
                    params={"reward_name": reward_name, "start_step": start_step, "num_steps": num_steps,
                            "terminal_weight": terminal_weight})


@configclass
class CurriculumCfg:
    terrain_levels = CurrTerm(func=mdp.terrain_levels_vel,
                              params={"command_name": COMMAND, "move_up_distance_m": 9.0, "move_down_distance_m": 2.0,
                                      "n_successes": 5, "n_failures": 10, "p_random_move_up": 0.01,
                                      "p_random_move_down": 0.05})
    pushing_velocity = CurrTerm(func=mdp.pushing_curriculum,
                                params={"max_vel": {"x": 0.5, "y": 0.5, "roll": 0.25, "pitch": 0.25, "yaw": 0.25},
                                        "min_vel": {"x": 0.2, "y": 0.2, "roll": 0.05, "pitch": 0.05, "yaw": 0.05},
                                        "fall_ratio_thresholds": (0.1, 0.5)})
    remove_harness = CurrTerm(func=mdp.remove_harness,
                              params={"harness_action_name": "harness", "start_step": 0, "num_steps": 50_000})
    action_rate = ramp("action_rate", -1.0, start_step=75_000)
    base_height_in_threshold = ramp("base_height_in_threshold", 1.0)
    track_lin_vel_xy_exp = ramp("track_lin_vel_xy_exp", 15.0)
    hip_pos_pen = ramp("hip_pos_pen", -5.0)


@configclass
class G1VelocityTeacherEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 4096
    decimation = 4  # 50 Hz policy, 200 Hz physics
    episode_length_s = 30.0
    clip_actions = 4.0  # AGILE's G1 velocity teacher: raw leg actions within ±4 (scale 0.25: ±1 rad of default)
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=256)
    commands = CommandsCfg()
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RewardsCfg()
    terminations = TerminationsCfg()
    events = velocity_teacher_events_cfg()
    curriculum = CurriculumCfg()
