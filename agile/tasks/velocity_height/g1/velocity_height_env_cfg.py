"""Velocity-Height-G1: Unitree G1 walks at a commanded planar velocity, or stands still at a commanded base
height between a deep crouch (0.4 m) and full stance (0.72 m), controlling its 12 leg joints.

AGILE `locomotion_height/g1/velocity_height_env_cfg.py` (FEB26): a privileged teacher (it sees its base
velocity; its critic also sees the terrain under its feet) learns by PPO, held up at first by a harness that a
curriculum removes over 50k env steps; the students see only what the robot measures and learn from the
teacher by distillation (no harness). Less-rough terrain with the terrain curriculum, domain randomisation,
pushes, and random waist-yaw and arm motions.

Configs (one builder, `velocity_height_env_cfg`, with the observation groups and whether the harness is on):
`teacher_env_cfg`, `recurrent_student_env_cfg`, `history_student_env_cfg`, `history_env_cfg` (PPO on the history
student's observations, no teacher), and the students' PPO fine-tuning after distillation
(`recurrent_student_finetune_env_cfg`, `history_student_finetune_env_cfg`).
"""

from __future__ import annotations

import dataclasses
import math

from agile.assets.unitree_g1 import ACTION_SCALE, LOWER_BODY_JOINTS
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import CurrTerm, DoneTerm, RewTerm, SceneEntityCfg
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import (BASE_HEIGHT_SENSOR, CONTACT_SENSOR, VelocityEventsCfg,
                                                  uniform_root_reset, velocity_events_cfg, velocity_sim_cfg)
from agile.tasks.velocity.g1.velocity_g1_common import (COMMAND, FEET, FEET_CONTACT, LEGS, STANDING_HEIGHT_M,
                                                        TRUNK_CONTACT_BODIES, PrivilegedCriticObsCfg,
                                                        PrivilegedPolicyObsCfg, velocity_height_scene_cfg)
from agile.utils.config import configclass

LEG_ACTION_SCALE = {expr: scale for expr, scale in ACTION_SCALE.items() if "hip" in expr or "knee" in expr
                    or "ankle" in expr}
"""AGILE `G1_ACTION_SCALE_LOWER`: 0.25·effort/kp per joint (hip pitch/yaw 0.548, hip roll/knee 0.351, ankles 0.439)."""
RAW_ACTION_CLIP = 6.0
"""AGILE clips the raw leg actions to ±6 (the action scale turns 1 into a quarter of the effort limit's PD offset, so
±6 spans every reachable target)."""


# -- commands ------------------------------------------------------------------------------------------

@configclass
class CommandsCfg:
    # standing (and so crouching) envs are a quarter of the draws, not AGILE's tenth: at a tenth, 2,500 iterations
    # left the crouch untrained (docs/velocity_height.md); AGILE trains 30k iterations
    base_velocity = mdp.UniformVelocityBaseHeightCommandCfg(
        height_sensor_name=BASE_HEIGHT_SENSOR,
        resampling_time_range_s=(7.5, 10.0), rel_standing_envs=0.25, ema_smoothing=0.5,
        default_height_m=STANDING_HEIGHT_M, min_walk_height_m=0.5, random_height_during_walking=False,
        ranges=mdp.VelocityHeightRangesCfg(lin_vel_x=(-0.5, 0.5), lin_vel_y=(-0.5, 0.5), ang_vel_z=(-1.0, 1.0),
                                           base_height_m=(0.4, STANDING_HEIGHT_M)))


# -- actions -------------------------------------------------------------------------------------------

def random_waist_and_arms_action_cfg() -> mdp.RandomActionCfg:
    """AGILE `random_upper_body_pos`: arms and waist yaw (±15°) move to random targets while the robot stands
    (back to their defaults while it walks); waist roll and pitch stay at 0."""
    return mdp.RandomActionCfg(
        joint_names_exclude=LOWER_BODY_JOINTS, sample_range_s=(0.1, 2.0), no_random_when_walking=True,
        command_name=COMMAND,
        joint_pos_limits={"waist_roll_joint": (0.0, 0.0), "waist_pitch_joint": (0.0, 0.0),
                          "waist_yaw_joint": (-math.radians(15.0), math.radians(15.0))},
        velocity_profile_cfg=mdp.TrapezoidalVelocityProfileCfg(
            acceleration_range=(1.0, 10.0), max_velocity_range=(5.0, 10.0), min_cruise_ratio=0.1,
            synchronize_joints=True, time_scaling_method="max_time"))


@configclass
class ActionsCfg:
    # AGILE clips the raw action to ±6 before scaling (RAW_ACTION_CLIP, the env's clip_actions);
    # JointPositionActionCfg.clip bounds the processed target instead, so it stays off here
    joint_pos = mdp.JointPositionActionCfg(joint_names=LOWER_BODY_JOINTS, scale=LEG_ACTION_SCALE,
                                           use_default_offset=True, clip=None)
    random_upper_body_pos = random_waist_and_arms_action_cfg()
    harness = mdp.HarnessActionCfg(body_name="pelvis", target_height_m=STANDING_HEIGHT_M, command_name=COMMAND,
                                   height_sensor=BASE_HEIGHT_SENSOR)


# -- observations --------------------------------------------------------------------------------------

def student_policy_obs_cfg(history_length: int | None = None) -> PrivilegedPolicyObsCfg:
    """AGILE `StudentVelocityPolicyCfg`: the privileged policy group without the base linear velocity, which
    the robot does not measure; `history_length` steps of it (None: the current step only)."""
    return dataclasses.replace(PrivilegedPolicyObsCfg(), base_lin_vel=None, history_length=history_length)


@configclass
class TeacherObservationsCfg:
    policy = PrivilegedPolicyObsCfg()
    critic = PrivilegedCriticObsCfg()


# -- rewards -------------------------------------------------------------------------------------------

@configclass
class RewardsCfg:
    # -- task
    termination_penalty = RewTerm(func=mdp.is_terminated, weight=-200.0)
    track_lin_vel_xy_exp = RewTerm(func=mdp.track_lin_vel_xy_yaw_frame_exp_weighted, weight=1.0,
                                   params={"command_name": COMMAND, "std": 0.2})
    # the reference gives no std for the yaw rate; 0.5 rad/s as AGILE V1.3's G1 velocity teacher: at 0.2 a 0.4 rad/s
    # error earned nothing, so nothing pulled it down (0.38 rad/s mean error)
    track_ang_vel_z_exp = RewTerm(func=mdp.track_ang_vel_z_world_exp, weight=1.0,
                                  params={"command_name": COMMAND, "std": 0.5})
    # weight 3 (AGILE: 1): a crouch costs the torso-orientation and relax terms more than a weight of 1 paid for it,
    # and the policy stood at 0.7 m whatever height it was told
    track_base_height_exp_smooth = RewTerm(func=mdp.track_base_height_exp_smooth, weight=3.0,
                                           params={"command_name": COMMAND, "std": 0.2,
                                                   "sensor_name": BASE_HEIGHT_SENSOR})
    no_undesired_base_velocity_exp = RewTerm(func=mdp.no_undesired_base_velocity_exp_if_null_cmd, weight=1.0,
                                             params={"command_name": COMMAND, "std": 0.1})
    equal_foot_force_if_null_cmd = RewTerm(func=mdp.equal_foot_force_if_null_cmd, weight=1.0,
                                           params={"command_name": COMMAND, "sensor_cfg": FEET_CONTACT})
    stand_with_both_feet_if_null_cmd = RewTerm(func=mdp.stand_with_both_feet_if_null_cmd, weight=1.0,
                                               params={"command_name": COMMAND, "threshold_n": 1.0,
                                                       "sensor_cfg": FEET_CONTACT})
    # -- joints and actions
    dof_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-1.0, params={"asset_cfg": LEGS})
    dof_vel_limits = RewTerm(func=mdp.joint_vel_limits, weight=-1.0, params={"asset_cfg": LEGS, "soft_ratio": 0.9})
    dof_vel_l2 = RewTerm(func=mdp.joint_vel_l2, weight=-1.0e-3, params={"asset_cfg": LEGS})
    torque_limits = RewTerm(func=mdp.applied_torque_limits, weight=-0.01, params={"asset_cfg": LEGS})
    dof_acc_l2 = RewTerm(func=mdp.joint_acc_l2, weight=-2.5e-7, params={"asset_cfg": LEGS})
    action_rate = RewTerm(func=mdp.action_rate_l2, weight=-0.01)
    action_rate_rate = RewTerm(func=mdp.action_rate_rate_l2, weight=-0.05)
    root_acc = RewTerm(func=mdp.body_acc_l2, weight=-2.0e-5,
                       params={"asset_cfg": SceneEntityCfg("robot", body_names="pelvis")})
    # AGILE's `ankle_pos_limits` term is `joint_pos_limits` on the ankles, ten times the legs' weight
    ankle_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-10.0,
                               params={"asset_cfg": SceneEntityCfg("robot", joint_names=".*_ankle_.*_joint")})
    hip_pos_pen = RewTerm(func=mdp.joint_deviation_l2, weight=-1.0,
                          params={"asset_cfg": SceneEntityCfg("robot", joint_names=[".*_hip_roll_joint",
                                                                                    ".*_hip_yaw_joint"])})
    # -- style
    relax_if_null_cmd = RewTerm(func=mdp.relax_if_null_cmd_exp, weight=1.0,
                                params={"command_name": COMMAND, "std": 0.25, "asset_cfg": LEGS})
    # Isaac Lab's `feet_slide` is `feet_slip`: foot horizontal speed while in contact (1 N)
    feet_slide = RewTerm(func=mdp.feet_slip, weight=-0.1, params={"sensor_cfg": FEET_CONTACT, "asset_cfg": FEET})
    feet_roll = RewTerm(func=mdp.feet_roll_l2, weight=-1.0, params={"asset_cfg": FEET})
    feet_yaw_diff = RewTerm(func=mdp.feet_yaw_diff_l2, weight=-0.2, params={"asset_cfg": FEET})
    feet_yaw_mean = RewTerm(func=mdp.feet_yaw_mean_vs_base, weight=-1.0,
                            params={"feet_asset_cfg": FEET,
                                    "base_body_cfg": SceneEntityCfg("robot", body_names="torso_link")})
    jumping_penalty = RewTerm(func=mdp.jumping, weight=-10.0,
                              params={"sensor_cfg": FEET_CONTACT, "force_threshold_n": 0.1})
    impact_velocity = RewTerm(func=mdp.impact_velocity_l1, weight=-0.5,
                              params={"sensor_cfg": FEET_CONTACT, "force_threshold_n": 10.0})
    flat_orientation = RewTerm(func=mdp.flat_orientation_l2, weight=-10.0,
                               params={"asset_cfg": SceneEntityCfg("robot", body_names="torso_link")})


# -- terminations --------------------------------------------------------------------------------------

@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)
    # the torso, as AGILE: the waist roll and pitch are held at 0 here, so the torso tilts with the pelvis
    base_orientation = DoneTerm(func=mdp.bad_orientation,
                                params={"limit_angle_rad": math.radians(40.0),
                                        "asset_cfg": SceneEntityCfg("robot", body_names="torso_link")})
    illegal_contacts = DoneTerm(func=mdp.illegal_ground_contact,
                                params={"force_threshold_n": 50.0, "min_height_m": 0.5,
                                        "sensor_cfg": SceneEntityCfg(CONTACT_SENSOR, body_names=TRUNK_CONTACT_BODIES),
                                        "asset_cfg": SceneEntityCfg("robot", body_names="torso_link")})
    feet_distance = DoneTerm(func=mdp.link_distance, params={"asset_cfg": FEET, "min_distance_m": 0.1,
                                                             "max_distance_m": 0.5})
    knee_distance = DoneTerm(func=mdp.link_distance,
                             params={"asset_cfg": SceneEntityCfg("robot", body_names=".*_knee_link"),
                                     "min_distance_m": 0.2})


# -- events --------------------------------------------------------------------------------------------

def velocity_height_events_cfg() -> VelocityEventsCfg:
    """AGILE `LocomotionEventCfg` of the height task: the velocity tasks' events with its own ranges (friction
    0.4-1.5 / 0.4-0.8; leg gains ×0.9-1.1 / 0.8-1.2, arm and waist gains ×0.5-2; armature ×0.4-1.6; torso
    +(-1..3) kg; 5 N / 2 N·m on the torso and 5 N / 0.5 N·m on the wrists every 2-10 s; joints reset ×0.8-2;
    pushes of 0.2 m/s and 0.05 rad/s)."""
    return velocity_events_cfg(
        base_body="torso_link", base_mass_add_kg=(-1.0, 3.0),
        base_com_range_m={"x": (-0.15, 0.15), "y": (-0.05, 0.05), "z": (-0.15, 0.15)},
        extremity_bodies=["left_wrist_yaw_link", "right_wrist_yaw_link"],
        static_friction=(0.4, 1.5), dynamic_friction=(0.4, 0.8), gain_joints=LEGS, damping_scale=(0.8, 1.2),
        upper_body_gain_joints=["waist_.*_joint", ".*_shoulder_.*_joint", ".*_elbow_joint", ".*_wrist_.*_joint"],
        upper_body_gain_scale=(0.5, 2.0), armature_scale=(0.4, 1.6), wrench_interval_s=(2.0, 10.0),
        base_wrench_n_nm=(5.0, 2.0), push_velocity=(0.2, 0.05),
        reset_base=uniform_root_reset(xy_range_m=2.5), joint_reset_position_scale=(0.8, 2.0))


# -- curriculum ----------------------------------------------------------------------------------------

@configclass
class CurriculumCfg:
    terrain_levels = CurrTerm(func=mdp.terrain_levels_vel,
                              params={"command_name": COMMAND, "move_up_distance_m": 4.0, "move_down_distance_m": 2.0,
                                      "n_successes": 5, "n_failures": 10})
    remove_harness = CurrTerm(func=mdp.remove_harness,
                              params={"harness_action_name": "harness", "start_step": 0, "num_steps": 50_000})
    action_rate = CurrTerm(func=mdp.update_reward_weight_step,
                           params={"reward_name": "action_rate", "start_step": 75_000, "num_steps": 50_000,
                                   "terminal_weight": -1.0})


# -- env configs: each one the whole MDP, from the blocks above -------------------------------------------

@configclass
class RecurrentStudentObservationsCfg:
    """The student's one step (its LSTM keeps the past), and the teacher's exact `policy` group as `teacher`."""

    policy = student_policy_obs_cfg()
    teacher = PrivilegedPolicyObsCfg()


STUDENT_HISTORY_LENGTH = 5


@configclass
class HistoryStudentObservationsCfg:
    """The student's last 5 steps (one tensor per term, for the mirror loss), and the teacher's `policy` group."""

    policy = student_policy_obs_cfg(history_length=STUDENT_HISTORY_LENGTH)
    teacher = PrivilegedPolicyObsCfg()


@configclass
class RecurrentFinetuneObservationsCfg:
    """PPO fine-tuning of the recurrent student: its `policy` group, the teacher's privileged critic."""

    policy = student_policy_obs_cfg()
    critic = PrivilegedCriticObsCfg()


@configclass
class HistoryObservationsCfg:
    """PPO without a teacher: the history student's `policy` group, the teacher's privileged critic."""

    policy = student_policy_obs_cfg(history_length=STUDENT_HISTORY_LENGTH)
    critic = PrivilegedCriticObsCfg()


def velocity_height_env_cfg(observations, harness: bool) -> ManagerBasedRLEnvCfg:
    """The task's MDP with these observation groups; with or without the training-only harness (and the
    curriculum that removes it). 200 Hz physics, 50 Hz policy, 30 s episodes."""
    actions, curriculum = ActionsCfg(), CurriculumCfg()
    if not harness:
        actions = dataclasses.replace(actions, harness=None)
        curriculum = dataclasses.replace(curriculum, remove_harness=None)
    return ManagerBasedRLEnvCfg(
        num_envs=4096, decimation=4, episode_length_s=30.0, clip_actions=RAW_ACTION_CLIP,
        scene=velocity_height_scene_cfg(), sim=velocity_sim_cfg(max_contacts_per_world=256),
        commands=CommandsCfg(), actions=actions, observations=observations, rewards=RewardsCfg(),
        terminations=TerminationsCfg(), events=velocity_height_events_cfg(), curriculum=curriculum)


def teacher_env_cfg() -> ManagerBasedRLEnvCfg:
    """AGILE `G1LowerVelocityHeightEnvCfg` (Velocity-Height-G1-v0): the privileged teacher, with the harness."""
    return velocity_height_env_cfg(TeacherObservationsCfg(), harness=True)


def recurrent_student_env_cfg() -> ManagerBasedRLEnvCfg:
    """Velocity-Height-G1-Student-Recurrent-v0: the teacher's MDP without the harness, distilled into an LSTM."""
    return velocity_height_env_cfg(RecurrentStudentObservationsCfg(), harness=False)


def history_student_env_cfg() -> ManagerBasedRLEnvCfg:
    """Velocity-Height-G1-Student-History-v0: the teacher's MDP without the harness, distilled into an MLP on
    5 steps of history."""
    return velocity_height_env_cfg(HistoryStudentObservationsCfg(), harness=False)


def history_env_cfg() -> ManagerBasedRLEnvCfg:
    """Velocity-Height-G1-History-v0 (AGILE V1.3 `G1VelocityHeightHistoryEnvCfg`): the teacher's MDP, harness
    and harness curriculum included (PPO learns from scratch as the teacher does), on the student's
    observations."""
    return velocity_height_env_cfg(HistoryObservationsCfg(), harness=True)


def recurrent_student_finetune_env_cfg() -> ManagerBasedRLEnvCfg:
    """Velocity-Height-G1-Student-Recurrent-Finetune-v0 (AGILE's `StudentFinetuneRecurrent`): the distilled
    recurrent student trained further by PPO, on the students' MDP (no harness) with a privileged critic."""
    return velocity_height_env_cfg(RecurrentFinetuneObservationsCfg(), harness=False)


def history_student_finetune_env_cfg() -> ManagerBasedRLEnvCfg:
    """Velocity-Height-G1-Student-History-Finetune-v0: the distilled history student trained further by PPO, on
    the students' MDP (no harness) with a privileged critic."""
    return velocity_height_env_cfg(HistoryObservationsCfg(), harness=False)
