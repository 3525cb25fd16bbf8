"""Blocks shared by the velocity tasks (identical in AGILE's T1 and G1 configs, with the robot's bodies as
arguments), built once here."""

from __future__ import annotations

import copy
import math

from agile.rl_env.managers import CurrTerm, DoneTerm, EventTerm, ObsGroup, ObsTerm, SceneEntityCfg, Unoise
from agile.sim.scene_cfg import ArticulationCfg, ContactSensorCfg, HeightScannerCfg, SceneCfg
from agile.sim.sim_cfg import SimCfg, SolverCfg
from agile.sim.terrain import TerrainGeneratorCfg
from agile.utils.config import configclass
from agile.tasks.velocity import mdp


def velocity_command_cfg() -> mdp.UniformNullVelocityCommandCfg:
    """vx, vy ±0.5 m/s, wz ±1 rad/s; resampled every 8-12 s; a quarter of the envs stand still."""
    return mdp.UniformNullVelocityCommandCfg(
        resampling_time_range_s=(8.0, 12.0), rel_standing_envs=0.25, min_vel_norm=0.1,
        ranges=mdp.VelocityRangesCfg(lin_vel_x=(-0.5, 0.5), lin_vel_y=(-0.5, 0.5), ang_vel_z=(-1.0, 1.0)))


BASE_HEIGHT_SENSOR = "height_measurement_sensor"
"""AGILE's one downward ray under the base: base height above the terrain for rewards and terminations."""
CONTACT_SENSOR = "contact_forces"
ROBOT_FRICTION_RANGE = (0.2, 1.0)
"""Dynamic friction drawn per robot collider at startup (AGILE: static 0.2-1.5, dynamic 0.2-1.0)."""


def velocity_scene_cfg(robot: ArticulationCfg, terrain: TerrainGeneratorCfg, base_body: str,
                       sensed_bodies: list[str]) -> SceneCfg:
    """The robot alone on a generated terrain whose curriculum starts every env on row 0 or 1 (AGILE's
    `max_init_terrain_level=1` for both velocity tasks; Isaac Lab's default is 5), a contact sensor on the
    bodies the contact terms read, and the base-height ray."""
    return SceneCfg(
        entities={"robot": robot},
        terrain=terrain, max_init_terrain_level=1, env_spacing_m=2.5,
        # a MuJoCo contact takes the larger friction of its two geoms: ground at the bottom of the robot's
        # randomised range lets each world's drawn foot friction decide (Isaac Lab multiplies by a ground of 1)
        ground_friction=ROBOT_FRICTION_RANGE[0],
        contact_sensors={CONTACT_SENSOR: ContactSensorCfg(entity="robot", body_names=sensed_bodies,
                                                          history_length=3, track_air_time=True)},
        height_scanners={BASE_HEIGHT_SENSOR: HeightScannerCfg(entity="robot", body_name=base_body)})


def velocity_sim_cfg(max_contacts_per_world: int, max_constraint_rows_per_world: int = 300) -> SimCfg:
    """200 Hz MuJoCo physics. Size the per-world contacts and constraint rows from a measurement (the peaks are
    logged under Physics/ and printed after a fallen-state collection): rows past `njmax` are dropped."""
    return SimCfg(physics_dt_s=0.005,
                  solver=SolverCfg(iterations=10, ls_iterations=20, njmax=max_constraint_rows_per_world,
                                   nconmax=max_contacts_per_world))


@configclass
class VelocityEventsCfg:
    """Domain randomisation (startup: each world draws its own robot once), disturbances and resets.
    Mass terms draw from the masses as built (Isaac Lab): the base-mass offset replaces the base's scale."""

    # -- startup
    physics_material = EventTerm(
        func=mdp.randomize_rigid_body_material, mode="startup",
        params={"static_friction_range": (0.2, 1.5), "dynamic_friction_range": ROBOT_FRICTION_RANGE,
                "restitution_range": (0.0, 0.1), "num_buckets": 64})
    actuator_gains = EventTerm(
        func=mdp.randomize_actuator_gains, mode="startup",
        params={"stiffness_distribution_params": (0.9, 1.1), "damping_distribution_params": (0.8, 2.0),
                "operation": "scale"})
    upper_body_actuator_gains: EventTerm | None = None
    """A second gain draw for other joints (AGILE's height task: the arms and waist), set by a task's builder."""
    joint_friction = EventTerm(
        func=mdp.randomize_joint_parameters, mode="startup",
        params={"friction_distribution_params": (0.0, 0.005), "operation": "abs"})
    joint_armature = EventTerm(
        func=mdp.randomize_joint_parameters, mode="startup",
        params={"armature_distribution_params": (0.0, 2.0), "operation": "scale"})
    body_mass = EventTerm(
        func=mdp.randomize_rigid_body_mass, mode="startup",
        params={"mass_distribution_params": (0.95, 1.05), "operation": "scale"})
    base_mass = EventTerm(func=mdp.randomize_rigid_body_mass, mode="startup",
                          params={"mass_distribution_params": (0.0, 0.0), "operation": "add"})
    body_com = EventTerm(func=mdp.randomize_rigid_body_com, mode="startup",
                         params={"com_range": {"x": (-0.01, 0.01), "y": (-0.01, 0.01), "z": (-0.01, 0.01)}})
    base_com = EventTerm(func=mdp.randomize_rigid_body_com, mode="startup", params={"com_range": {}})
    # -- interval
    base_external_wrench = EventTerm(func=mdp.apply_external_force_torque, mode="interval", interval_range_s=(0.0, 10.0),
                                     params={"force_range": (-10.0, 10.0), "torque_range": (-5.0, 5.0)})
    extremities_external_wrench = EventTerm(func=mdp.apply_external_force_torque, mode="interval",
                                            interval_range_s=(0.0, 10.0),
                                            params={"force_range": (-5.0, 5.0), "torque_range": (-0.5, 0.5)})
    push_robot = EventTerm(
        func=mdp.push_by_setting_velocity, mode="interval", interval_range_s=(2.0, 5.0),
        params={"velocity_range": {"x": (-0.5, 0.5), "y": (-0.5, 0.5), "roll": (-0.25, 0.25),
                                   "pitch": (-0.25, 0.25), "yaw": (-0.25, 0.25)}})
    # -- reset
    reset_base = EventTerm(
        func=mdp.reset_root_state_uniform, mode="reset",
        params={"pose_range": {"x": (-2.5, 2.5), "y": (-2.5, 2.5), "roll": (-math.radians(10), math.radians(10)),
                               "pitch": (-math.radians(10), math.radians(10)), "yaw": (-math.pi, math.pi)},
                "velocity_range": {"x": (-0.25, 0.25), "y": (-0.25, 0.25), "roll": (-0.5, 0.5),
                                   "pitch": (-0.5, 0.5), "yaw": (-0.5, 0.5)}})
    reset_robot_joints = EventTerm(
        func=mdp.reset_joints_by_scale, mode="reset",
        params={"position_range": (0.8, 1.2), "velocity_range": (-1.0, 1.0)})


def velocity_events_cfg(base_body: str, base_mass_add_kg: tuple[float, float],
                        base_com_range_m: dict[str, tuple[float, float]], extremity_bodies: list[str]) -> VelocityEventsCfg:
    """The events with the robot's base (extra mass, centre-of-mass shift, 10 N pushes) and extremities
    (hands and feet: 5 N pushes)."""
    cfg = VelocityEventsCfg()
    base = SceneEntityCfg("robot", body_names=base_body)
    cfg.base_mass.params.update(mass_distribution_params=base_mass_add_kg, asset_cfg=base)
    cfg.base_com.params.update(com_range=base_com_range_m, asset_cfg=base)
    cfg.base_external_wrench.params["asset_cfg"] = base
    cfg.extremities_external_wrench.params["asset_cfg"] = SceneEntityCfg("robot", body_names=extremity_bodies)
    return cfg


def random_upper_body_action_cfg(excluded_joints: list[str]) -> mdp.RandomActionCfg:
    """AGILE `random_pos`: every joint but the legs and waist (`excluded_joints`) moves to random targets on
    trapezoidal velocity profiles, new targets every 0.1-2.5 s, so the policy learns to walk with moving arms.
    A waist joint the policy does not control keeps its default target."""
    return mdp.RandomActionCfg(
        joint_names_exclude=excluded_joints, sample_range_s=(0.1, 2.5),
        velocity_profile_cfg=mdp.TrapezoidalVelocityProfileCfg(
            acceleration_range=(1.0, 20.0), max_velocity_range=(10.0, 20.0), min_cruise_ratio=0.1,
            synchronize_joints=True, time_scaling_method="max_time"))


@configclass
class VelocityPolicyObsCfg(ObsGroup):
    """What the policy sees: 5 steps of history, noisy, one tensor per term (AGILE's TD groups)."""

    concatenate_terms = False
    enable_corruption = True
    history_length = 5
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel, scale=0.2, noise=Unoise(-0.2, 0.2))
    projected_gravity = ObsTerm(func=mdp.projected_gravity, noise=Unoise(-0.05, 0.05))
    velocity_commands = ObsTerm(func=mdp.generated_commands, params={"command_name": "base_velocity"})
    controlled_joint_pos = ObsTerm(func=mdp.joint_pos_rel, noise=Unoise(-0.01, 0.01))
    controlled_joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.05, noise=Unoise(-1.5, 1.5))
    actions = ObsTerm(func=mdp.last_action)


def velocity_policy_obs_cfg(controlled: SceneEntityCfg) -> VelocityPolicyObsCfg:
    """The policy group, with the joint terms on the controlled joints."""
    cfg = VelocityPolicyObsCfg()
    cfg.controlled_joint_pos.params["asset_cfg"] = controlled
    cfg.controlled_joint_vel.params["asset_cfg"] = controlled
    return cfg


@configclass
class VelocityCriticObsCfg(ObsGroup):
    """What the critic sees: noise-free, with the base linear velocity and every joint."""

    velocity_commands = ObsTerm(func=mdp.generated_commands, params={"command_name": "base_velocity"})
    base_lin_vel = ObsTerm(func=mdp.base_lin_vel)
    base_ang_vel = ObsTerm(func=mdp.base_ang_vel)
    projected_gravity = ObsTerm(func=mdp.projected_gravity)
    joint_pos = ObsTerm(func=mdp.joint_pos_rel)
    joint_vel = ObsTerm(func=mdp.joint_vel_rel, scale=0.1)
    actions = ObsTerm(func=mdp.last_action)


@configclass
class VelocityTerminationsCfg:
    # orientation on the root, as in AGILE (its configs name Trunk / torso_link, but Isaac Lab's bad_orientation
    # reads the root): on G1 a torso limit (the torso tilts with the waist joints) ended 100% of the early
    # episodes and collapsed the policy's action noise (measured at iteration 50)
    time_out = DoneTerm(func=mdp.time_out, time_out=True)
    bad_orientation = DoneTerm(func=mdp.bad_orientation, params={"limit_angle_rad": math.radians(30.0)})
    illegal_ground_contact = DoneTerm(func=mdp.illegal_ground_contact,
                                      params={"force_threshold_n": 20.0, "min_height_m": 0.45})
    illegal_base_height = DoneTerm(func=mdp.root_height_below_minimum,
                                   params={"minimum_height_m": 0.0, "sensor_name": BASE_HEIGHT_SENSOR})


def velocity_terminations_cfg(base_height_target_m: float, trunk_bodies: list[str]) -> VelocityTerminationsCfg:
    """Time-out; root tilted beyond 30°; a trunk body pushing on something (> 20 N) while one of them is below
    0.45 m; root more than 0.3 m below its target height above the terrain."""
    cfg = VelocityTerminationsCfg()
    cfg.illegal_ground_contact.params.update(sensor_cfg=SceneEntityCfg(CONTACT_SENSOR, body_names=trunk_bodies),
                                             asset_cfg=SceneEntityCfg("robot", body_names=trunk_bodies))
    cfg.illegal_base_height.params["minimum_height_m"] = base_height_target_m - 0.3
    return cfg


@configclass
class VelocityCurriculumCfg:
    terrain_levels = CurrTerm(func=mdp.terrain_levels_vel,
                              params={"command_name": "base_velocity", "move_up_distance_m": 4.0,
                                      "move_down_distance_m": 2.0, "n_successes": 4, "n_failures": 10})
    action_rate = CurrTerm(func=mdp.update_reward_weight_step,
                           params={"reward_name": "action_rate", "start_step": 50_000, "num_steps": 100_000,
                                   "terminal_weight": 0.0})
    action_rate_rate = CurrTerm(func=mdp.update_reward_weight_step,
                                params={"reward_name": "action_rate_rate", "start_step": 60_000,
                                        "num_steps": 100_000, "terminal_weight": 0.0})


def velocity_curriculum_cfg(action_rate_final: float, action_rate_rate_final: float) -> VelocityCurriculumCfg:
    """Terrain rows by distance walked (up after 4 episodes beyond 4 m, down after 10 short of 2 m); the
    action-rate penalties ramp from 50k (and 60k) env steps over 100k steps to their final weights."""
    cfg = VelocityCurriculumCfg()
    cfg.action_rate.params["terminal_weight"] = action_rate_final
    cfg.action_rate_rate.params["terminal_weight"] = action_rate_rate_final
    return cfg


RANDOMISATION_EVENTS = ("physics_material", "actuator_gains", "upper_body_actuator_gains", "joint_friction",
                        "joint_armature", "body_mass", "base_mass", "body_com", "base_com", "base_external_wrench",
                        "extremities_external_wrench")
"""The startup domain randomisation and the random wrenches of `VelocityEventsCfg` (pushes and resets stay)."""


def without_randomisation(events: VelocityEventsCfg, reset_xy_range_m: float) -> VelocityEventsCfg:
    """A copy of the events with no domain randomisation or random wrenches (the conditions the shipped G1 policy
    learned in), and reset positions drawn within ±`reset_xy_range_m` of the robot's spawn point."""
    events = copy.deepcopy(events)
    for name in RANDOMISATION_EVENTS:
        setattr(events, name, None)
    pose_range = events.reset_base.params["pose_range"]
    pose_range.update(x=(-reset_xy_range_m, reset_xy_range_m), y=(-reset_xy_range_m, reset_xy_range_m))
    return events
