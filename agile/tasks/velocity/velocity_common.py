"""Blocks shared by the velocity tasks (identical in AGILE's T1 and G1 configs, with the robot's bodies as
arguments), built once here."""

from __future__ import annotations

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
                       sensed_bodies: list[str], max_init_terrain_level: int = 1,
                       ground_friction: float = ROBOT_FRICTION_RANGE[0],
                       extra_height_scanners: dict[str, HeightScannerCfg] | None = None) -> SceneCfg:
    """The robot alone on a generated terrain whose curriculum starts every env on a row up to
    `max_init_terrain_level` (AGILE's velocity tasks: 1; Isaac Lab's default is 5), a contact sensor on the bodies
    the contact terms read, the base-height ray and any other height scanners. A MuJoCo contact takes the larger
    friction of its two geoms: `ground_friction` at the bottom of the robot's randomised range lets each world's
    drawn foot friction decide (Isaac Lab multiplies by a ground of 1)."""
    return SceneCfg(
        entities={"robot": robot},
        terrain=terrain, max_init_terrain_level=max_init_terrain_level, env_spacing_m=2.5,
        ground_friction=ground_friction,
        contact_sensors={CONTACT_SENSOR: ContactSensorCfg(entity="robot", body_names=sensed_bodies,
                                                          history_length=3, track_air_time=True)},
        height_scanners={BASE_HEIGHT_SENSOR: HeightScannerCfg(entity="robot", body_name=base_body),
                         **(extra_height_scanners or {})})


def velocity_sim_cfg(max_contacts_per_world: int, max_constraint_rows_per_world: int = 300) -> SimCfg:
    """200 Hz MuJoCo physics. Size the per-world contacts and constraint rows from a measurement (the peaks are
    logged under Physics/ and printed after a fallen-state collection): rows past `njmax` are dropped."""
    return SimCfg(physics_dt_s=0.005,
                  solver=SolverCfg(iterations=10, ls_iterations=20, njmax=max_constraint_rows_per_world,
                                   nconmax=max_contacts_per_world))


@configclass
class VelocityEventsCfg:
    """Domain randomisation (startup: each world draws its own robot once), disturbances and resets, in the order
    they apply; a term that is None is off. Built by `velocity_events_cfg`."""

    # -- startup (the second gain draw first: the order these draws have always run in, so the shipped policies'
    # worlds are drawn as they were trained)
    upper_body_actuator_gains: EventTerm | None = None
    physics_material: EventTerm | None = None
    actuator_gains: EventTerm | None = None
    joint_friction: EventTerm | None = None
    joint_armature: EventTerm | None = None
    body_mass: EventTerm | None = None
    base_mass: EventTerm | None = None
    body_com: EventTerm | None = None
    base_com: EventTerm | None = None
    # -- interval
    base_external_wrench: EventTerm | None = None
    extremities_external_wrench: EventTerm | None = None
    push_robot: EventTerm | None = None
    # -- reset
    reset_base: EventTerm | None = None
    reset_robot_joints: EventTerm | None = None


def _symmetric(value: float) -> tuple[float, float]:
    return (-value, value)


def uniform_root_reset(xy_range_m: float, z_range_m: float | None = None) -> EventTerm:
    """Reset the root at its spawn pose plus uniform offsets: x and y within ±`xy_range_m`, z within ±`z_range_m`
    (None: none), roll and pitch within ±10°, any yaw; velocities up to 0.25 m/s and 0.5 rad/s."""
    pose_range = {"x": _symmetric(xy_range_m), "y": _symmetric(xy_range_m),
                  "roll": (-math.radians(10), math.radians(10)), "pitch": (-math.radians(10), math.radians(10)),
                  "yaw": (-math.pi, math.pi)}
    if z_range_m is not None:
        pose_range["z"] = _symmetric(z_range_m)
    return EventTerm(func=mdp.reset_root_state_uniform, mode="reset",
                     params={"pose_range": pose_range,
                             "velocity_range": {"x": (-0.25, 0.25), "y": (-0.25, 0.25), "roll": (-0.5, 0.5),
                                                "pitch": (-0.5, 0.5), "yaw": (-0.5, 0.5)}})


def velocity_events_cfg(
        *, base_body: str, extremity_bodies: list[str], base_mass_add_kg: tuple[float, float],
        base_com_range_m: dict[str, tuple[float, float]], reset_base: EventTerm,
        joint_reset_position_scale: tuple[float, float] | None = (0.8, 1.2), randomise: bool = True,
        static_friction: tuple[float, float] = (0.2, 1.5),
        dynamic_friction: tuple[float, float] = ROBOT_FRICTION_RANGE, restitution: tuple[float, float] = (0.0, 0.1),
        gain_joints: SceneEntityCfg | None = None, stiffness_scale: tuple[float, float] = (0.9, 1.1),
        damping_scale: tuple[float, float] = (0.8, 2.0), upper_body_gain_joints: list[str] | None = None,
        upper_body_gain_scale: tuple[float, float] = (0.5, 2.0),
        joint_friction_nm: tuple[float, float] | None = (0.0, 0.005),
        armature_scale: tuple[float, float] | None = (0.0, 2.0), body_mass_scale: tuple[float, float] = (0.95, 1.05),
        body_com_shift_m: float | None = 0.01, wrench_interval_s: tuple[float, float] = (0.0, 10.0),
        base_wrench_n_nm: tuple[float, float] = (10.0, 5.0), extremity_wrench_n_nm: tuple[float, float] = (5.0, 0.5),
        push_interval_s: tuple[float, float] = (2.0, 5.0), push_velocity: tuple[float, float] = (0.5, 0.25),
) -> VelocityEventsCfg:
    """The events of AGILE's locomotion tasks, every range an argument (defaults: its velocity tasks' `EventCfg`).

    Startup (skipped with `randomise=False`, as are the random wrenches): collider friction (`static_friction`,
    `dynamic_friction`) and restitution; PD gains scaled on `gain_joints` (None: every joint) and, where
    `upper_body_gain_joints` is given, a second draw of `upper_body_gain_scale` on those; joint friction [N·m] and
    armature scale (None: off); body masses scaled, the base's mass offset [kg] and its centre-of-mass shift [m];
    every body's centre of mass shifted up to `body_com_shift_m` (None: off). Interval: random wrenches
    (force [N], torque [N·m]) on the base and on `extremity_bodies`, new every `wrench_interval_s`; pushes that set
    the base velocity to up to `push_velocity` (m/s in x and y, rad/s about each axis) every `push_interval_s`.
    Reset: `reset_base` (e.g. `uniform_root_reset`), then joints at the default pose scaled by
    `joint_reset_position_scale` with velocities up to 1 rad/s (None: the reset term sets the joints)."""
    base = SceneEntityCfg("robot", body_names=base_body)
    on = randomise
    gain_params = {"stiffness_distribution_params": stiffness_scale, "damping_distribution_params": damping_scale,
                   "operation": "scale"}
    if gain_joints is not None:
        gain_params["asset_cfg"] = gain_joints
    lin, ang = push_velocity
    return VelocityEventsCfg(
        physics_material=EventTerm(
            func=mdp.randomize_rigid_body_material, mode="startup",
            params={"static_friction_range": static_friction, "dynamic_friction_range": dynamic_friction,
                    "restitution_range": restitution, "num_buckets": 64}) if on else None,
        actuator_gains=EventTerm(func=mdp.randomize_actuator_gains, mode="startup", params=gain_params) if on else None,
        upper_body_actuator_gains=EventTerm(
            func=mdp.randomize_actuator_gains, mode="startup",
            params={"stiffness_distribution_params": upper_body_gain_scale,
                    "damping_distribution_params": upper_body_gain_scale, "operation": "scale",
                    "asset_cfg": SceneEntityCfg("robot", joint_names=upper_body_gain_joints)})
        if on and upper_body_gain_joints is not None else None,
        joint_friction=EventTerm(
            func=mdp.randomize_joint_parameters, mode="startup",
            params={"friction_distribution_params": joint_friction_nm, "operation": "abs"})
        if on and joint_friction_nm is not None else None,
        joint_armature=EventTerm(
            func=mdp.randomize_joint_parameters, mode="startup",
            params={"armature_distribution_params": armature_scale, "operation": "scale"})
        if on and armature_scale is not None else None,
        body_mass=EventTerm(func=mdp.randomize_rigid_body_mass, mode="startup",
                            params={"mass_distribution_params": body_mass_scale, "operation": "scale"}) if on else None,
        base_mass=EventTerm(func=mdp.randomize_rigid_body_mass, mode="startup",
                            params={"mass_distribution_params": base_mass_add_kg, "operation": "add",
                                    "asset_cfg": base}) if on else None,
        body_com=EventTerm(func=mdp.randomize_rigid_body_com, mode="startup",
                           params={"com_range": {axis: _symmetric(body_com_shift_m) for axis in "xyz"}})
        if on and body_com_shift_m is not None else None,
        base_com=EventTerm(func=mdp.randomize_rigid_body_com, mode="startup",
                           params={"com_range": base_com_range_m, "asset_cfg": base}) if on else None,
        base_external_wrench=EventTerm(
            func=mdp.apply_external_force_torque, mode="interval", interval_range_s=wrench_interval_s,
            params={"force_range": _symmetric(base_wrench_n_nm[0]), "torque_range": _symmetric(base_wrench_n_nm[1]),
                    "asset_cfg": base}) if on else None,
        extremities_external_wrench=EventTerm(
            func=mdp.apply_external_force_torque, mode="interval", interval_range_s=wrench_interval_s,
            params={"force_range": _symmetric(extremity_wrench_n_nm[0]),
                    "torque_range": _symmetric(extremity_wrench_n_nm[1]),
                    "asset_cfg": SceneEntityCfg("robot", body_names=extremity_bodies)}) if on else None,
        push_robot=EventTerm(
            func=mdp.push_by_setting_velocity, mode="interval", interval_range_s=push_interval_s,
            params={"velocity_range": {"x": _symmetric(lin), "y": _symmetric(lin), "roll": _symmetric(ang),
                                       "pitch": _symmetric(ang), "yaw": _symmetric(ang)}}),
        reset_base=reset_base,
        reset_robot_joints=EventTerm(
            func=mdp.reset_joints_by_scale, mode="reset",
            params={"position_range": joint_reset_position_scale, "velocity_range": (-1.0, 1.0)})
        if joint_reset_position_scale is not None else None)


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
    # every term annotated: configclass puts annotated fields before unannotated ones, and the terms' order is the
    # policy's input layout
    base_ang_vel: ObsTerm = ObsTerm(func=mdp.base_ang_vel, scale=0.2, noise=Unoise(-0.2, 0.2))
    projected_gravity: ObsTerm = ObsTerm(func=mdp.projected_gravity, noise=Unoise(-0.05, 0.05))
    velocity_commands: ObsTerm = ObsTerm(func=mdp.generated_commands, params={"command_name": "base_velocity"})
    controlled_joint_pos: ObsTerm | None = None
    controlled_joint_vel: ObsTerm | None = None
    actions: ObsTerm = ObsTerm(func=mdp.last_action)


def velocity_policy_obs_cfg(controlled: SceneEntityCfg) -> VelocityPolicyObsCfg:
    """The policy group, with the joint terms on the controlled joints."""
    return VelocityPolicyObsCfg(
        controlled_joint_pos=ObsTerm(func=mdp.joint_pos_rel, noise=Unoise(-0.01, 0.01),
                                     params={"asset_cfg": controlled}),
        controlled_joint_vel=ObsTerm(func=mdp.joint_vel_rel, scale=0.05, noise=Unoise(-1.5, 1.5),
                                     params={"asset_cfg": controlled}))


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
    time_out: DoneTerm | None = None
    bad_orientation: DoneTerm | None = None
    illegal_ground_contact: DoneTerm | None = None
    illegal_base_height: DoneTerm | None = None


def velocity_terminations_cfg(base_height_target_m: float, trunk_bodies: list[str], *, max_tilt_deg: float = 30.0,
                              contact_min_height_m: float = 0.45,
                              height_margin_m: float = 0.3) -> VelocityTerminationsCfg:
    """Time-out; root tilted beyond `max_tilt_deg`; a trunk body pushing on something (> 20 N) while one of them is
    below `contact_min_height_m`; root more than `height_margin_m` below its target height above the terrain.
    The defaults are the humanoids' (AGILE); a quadruped, whose trunk is always low, passes its own."""
    # orientation on the root, as in AGILE (its configs name Trunk / torso_link, but Isaac Lab's bad_orientation
    # reads the root): on G1 a torso limit (the torso tilts with the waist joints) ended 100% of the early
    # episodes and collapsed the policy's action noise (measured at iteration 50)
    return VelocityTerminationsCfg(
        time_out=DoneTerm(func=mdp.time_out, time_out=True),
        bad_orientation=DoneTerm(func=mdp.bad_orientation, params={"limit_angle_rad": math.radians(max_tilt_deg)}),
        illegal_ground_contact=DoneTerm(
            func=mdp.illegal_ground_contact,
            params={"force_threshold_n": 20.0, "min_height_m": contact_min_height_m,
                    "sensor_cfg": SceneEntityCfg(CONTACT_SENSOR, body_names=trunk_bodies),
                    "asset_cfg": SceneEntityCfg("robot", body_names=trunk_bodies)}),
        illegal_base_height=DoneTerm(
            func=mdp.root_height_below_minimum,
            params={"minimum_height_m": base_height_target_m - height_margin_m, "sensor_name": BASE_HEIGHT_SENSOR}))


@configclass
class VelocityCurriculumCfg:
    terrain_levels: CurrTerm | None = None
    action_rate: CurrTerm | None = None
    action_rate_rate: CurrTerm | None = None
    command_levels: CurrTerm | None = None


def velocity_curriculum_cfg(action_rate_final: float, action_rate_rate_final: float) -> VelocityCurriculumCfg:
    """Terrain rows by distance walked (up after 4 episodes beyond 4 m, down after 10 short of 2 m); the
    action-rate penalties ramp from 50k (and 60k) env steps over 100k steps to their final weights. The command-range
    curriculum (not AGILE's) is off: `env.curriculum.command_levels.params.start_fraction=0.3` turns it on."""
    return VelocityCurriculumCfg(
        terrain_levels=CurrTerm(func=mdp.terrain_levels_vel,
                                params={"command_name": "base_velocity", "move_up_distance_m": 4.0,
                                        "move_down_distance_m": 2.0, "n_successes": 4, "n_failures": 10}),
        action_rate=CurrTerm(func=mdp.update_reward_weight_step,
                             params={"reward_name": "action_rate", "start_step": 50_000, "num_steps": 100_000,
                                     "terminal_weight": action_rate_final}),
        action_rate_rate=CurrTerm(func=mdp.update_reward_weight_step,
                                  params={"reward_name": "action_rate_rate", "start_step": 60_000,
                                          "num_steps": 100_000, "terminal_weight": action_rate_rate_final}),
        command_levels=CurrTerm(func=mdp.velocity_command_levels,
                                params={"reward_names": ["track_lin_vel_xy_exp", "track_ang_vel"],
                                        "start_fraction": 1.0, "step_fraction": 0.1, "threshold": 0.5,
                                        "interval_steps": 1000}))


