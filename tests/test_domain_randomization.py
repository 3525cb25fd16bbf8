"""Domain randomisation events, random upper-body actions and body_acc_l2, on real physics (CPU, 3 worlds)."""

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
import torch
import warp as wp

from agile.assets.booster_t1 import t1_delayed_dc_motor_actuators, t1_implicit_actuators, t1_robot_cfg
from agile.rl_env import mdp
from agile.rl_env.managers import ActionManager, SceneEntityCfg
from fakes import FakeEnv
from scenes import robot_sim

NUM_ENVS = 3
STEP_DT_S = 0.02
PHYSICS_STEPS_PER_ENV_STEP = 4
GRAVITY_MPS2 = 9.81


def make_env(actuators: dict) -> SimpleNamespace:
    """What event and reward terms read from an env (scene, sim, sizes), without the managers."""
    sim = robot_sim(t1_robot_cfg(actuators), NUM_ENVS, STEP_DT_S, ground_friction=0.1)
    return SimpleNamespace(sim=sim, robot=sim.scene["robot"], scene=sim.scene, num_envs=NUM_ENVS,
                           device=sim.device, step_dt=STEP_DT_S)


@pytest.fixture(scope="module")
def env():
    return make_env(t1_implicit_actuators())


def entity(env, **names) -> SceneEntityCfg:
    cfg = SceneEntityCfg("robot", **names)
    cfg.resolve(env)
    return cfg


def all_envs(env) -> torch.Tensor:
    return torch.ones(env.num_envs, dtype=torch.bool)


def mujoco_values_per_world(mjw_field: wp.array, mjc_to_newton: wp.array, newton_values: torch.Tensor):
    """(mujoco value, newton value) pairs for every mapped entry of every world."""
    mj = mjw_field.numpy()
    index = mjc_to_newton.numpy()
    newton_np = newton_values.cpu().numpy()
    pairs = [(mj[w, k], newton_np[index[w, k]]) for w in range(index.shape[0]) for k in range(index.shape[1])
             if index[w, k] >= 0]
    return np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])


def settle(env, env_steps: int) -> None:
    for _ in range(env_steps):
        env.sim.step(PHYSICS_STEPS_PER_ENV_STEP)
    env.robot.update()


# -- model parameters --------------------------------------------------------------------------------

def test_mass_randomisation_is_per_world_in_range_and_reaches_mujoco(env):
    robot = env.robot
    mass0, inertia0 = robot.default_body_mass.clone(), robot.body_inertia.clone()
    torch.testing.assert_close(robot.body_mass, mass0)  # nothing randomised yet
    mdp.randomize_rigid_body_mass(env, all_envs(env), mass_distribution_params=(0.95, 1.05), operation="scale",
                                  asset_cfg=entity(env))
    scale = robot.body_mass / mass0
    assert ((scale >= 0.95 - 1e-6) & (scale <= 1.05 + 1e-6)).all()
    assert not torch.allclose(scale[0], scale[1])
    torch.testing.assert_close(robot.body_inertia, inertia0 * scale[..., None, None])

    scaled = robot.body_mass.clone()
    mdp.randomize_rigid_body_mass(env, all_envs(env), mass_distribution_params=(-1.0, 3.0), operation="add",
                                  asset_cfg=entity(env, body_names="Trunk"))
    added = robot.body_mass[:, 0] - mass0[:, 0]  # on the trunk's mass as built: its scale is replaced
    assert ((added >= -1.0 - 1e-5) & (added <= 3.0 + 1e-5)).all() and added.unique().numel() == NUM_ENVS
    torch.testing.assert_close(robot.body_mass[:, 1:], scaled[:, 1:])
    ratio = robot.body_mass[:, 0] / mass0[:, 0]
    torch.testing.assert_close(robot.body_inertia[:, 0], inertia0[:, 0] * ratio[:, None, None])

    solver = env.sim.solver
    mj, newton_mass = mujoco_values_per_world(solver.mjw_model.body_mass, solver.mjc_body_to_newton,
                                              wp.to_torch(env.sim.model.body_mass))
    np.testing.assert_allclose(mj, newton_mass, rtol=1e-6)


def test_heavier_base_in_one_world_changes_only_that_world():
    env = make_env(t1_implicit_actuators())
    robot, solver = env.robot, env.sim.solver
    mujoco_mass0 = solver.mjw_model.body_mass.numpy().copy()
    only_world_1 = torch.tensor([False, True, False])
    mdp.randomize_rigid_body_mass(env, only_world_1, mass_distribution_params=(10.0, 10.0), operation="add",
                                  asset_cfg=entity(env, body_names="Trunk"))
    changed = solver.mjw_model.body_mass.numpy() != mujoco_mass0
    assert changed[1].sum() == 1 and not changed[0].any() and not changed[2].any()

    settle(env, 10)  # stand on the PD-held default pose
    robot.compute_pd_torque()
    knees, _ = robot.find_joints(".*Knee.*")
    knee_torque = robot.applied_torque[:, knees].abs().sum(dim=1)
    torch.testing.assert_close(knee_torque[0], knee_torque[2])  # identical worlds stay identical
    assert knee_torque[1] > knee_torque[0] * 1.1


def test_com_offsets_are_per_world_in_range_and_reach_mujoco(env):
    robot, solver = env.robot, env.sim.solver
    com0 = robot.body_com_b.clone()
    mdp.randomize_rigid_body_com(env, all_envs(env), com_range={"x": (-0.15, 0.15), "y": (-0.05, 0.05)},
                                 asset_cfg=entity(env, body_names="Trunk"))
    offset = robot.body_com_b - com0
    assert (offset[:, 0, 0].abs() <= 0.15).all() and (offset[:, 0, 1].abs() <= 0.05).all()
    assert (offset[:, 0, 2] == 0).all() and (offset[:, 1:] == 0).all()
    assert offset[:, 0, 0].unique().numel() == NUM_ENVS
    mj, newton_com = mujoco_values_per_world(solver.mjw_model.body_ipos, solver.mjc_body_to_newton,
                                             wp.to_torch(env.sim.model.body_com))
    np.testing.assert_allclose(mj, newton_com, atol=1e-6)


def test_material_friction_is_per_world_in_range_and_reaches_geom_friction(env):
    model, solver = env.sim.model, env.sim.solver
    mdp.randomize_rigid_body_material(env, all_envs(env), static_friction_range=(0.2, 1.5),
                                      dynamic_friction_range=(0.2, 1.0), restitution_range=(0.0, 0.1),
                                      num_buckets=64, asset_cfg=entity(env))
    robot_shapes = model.shape_world.numpy() >= 0
    mu = model.shape_material_mu.numpy()[robot_shapes].reshape(NUM_ENVS, -1)
    restitution = model.shape_material_restitution.numpy()[robot_shapes]
    assert ((mu >= 0.2) & (mu <= 1.0)).all() and ((restitution >= 0.0) & (restitution <= 0.1)).all()
    assert not np.allclose(mu[0], mu[1])
    assert model.shape_material_mu.numpy()[~robot_shapes] == pytest.approx(0.1)  # the ground keeps its own
    mj, newton_mu = mujoco_values_per_world(solver.mjw_model.geom_friction, solver.mjc_geom_to_newton_shape,
                                            wp.to_torch(model.shape_material_mu))
    np.testing.assert_allclose(mj[:, 0], newton_mu, rtol=1e-6)


def test_implicit_gains_reach_mujoco_actuators(env):
    robot, solver = env.robot, env.sim.solver
    kp0, kd0 = robot.joint_stiffness.clone(), robot.joint_damping.clone()
    mdp.randomize_actuator_gains(env, all_envs(env), stiffness_distribution_params=(0.9, 1.1),
                                 damping_distribution_params=(0.8, 2.0), asset_cfg=entity(env))
    kp_scale, kd_scale = robot.joint_stiffness / kp0, robot.joint_damping / kd0
    assert ((kp_scale >= 0.9 - 1e-6) & (kp_scale <= 1.1 + 1e-6)).all()
    assert ((kd_scale >= 0.8 - 1e-6) & (kd_scale <= 2.0 + 1e-6)).all()
    assert not torch.allclose(kp_scale[0], kp_scale[1])
    # MuJoCo position actuator: gain kp, bias (0, -kp, -kd); actuator k drives DoF index[k] of each world
    dof = solver.mjc_actuator_to_newton_idx.numpy()
    gain = solver.mjw_model.actuator_gainprm.numpy()[:, :, 0]
    bias = solver.mjw_model.actuator_biasprm.numpy()[:, :, 2]
    np.testing.assert_allclose(gain, robot.joint_stiffness.numpy()[:, dof - 6], rtol=1e-6)
    np.testing.assert_allclose(-bias, robot.joint_damping.numpy()[:, dof - 6], rtol=1e-6)


def test_explicit_actuator_gains_follow_the_model():
    env = make_env(t1_delayed_dc_motor_actuators())
    robot = env.robot
    mdp.randomize_actuator_gains(env, all_envs(env), stiffness_distribution_params=(0.9, 1.1),
                                 damping_distribution_params=(0.8, 2.0), asset_cfg=entity(env))
    (group,) = env.sim.actuator_groups
    torch.testing.assert_close(group.stiffness, robot.joint_stiffness[:, group.joint_ids])
    torch.testing.assert_close(group.damping, robot.joint_damping[:, group.joint_ids])
    # the torque model reads these tensors' memory
    assert wp.to_torch(group.actuator.drive.kp).data_ptr() == group.stiffness.data_ptr()
    assert wp.to_torch(group.actuator.drive.kd).data_ptr() == group.damping.data_ptr()


def test_joint_friction_and_armature_reach_mujoco_dofs(env):
    robot, solver = env.robot, env.sim.solver
    armature0 = robot.joint_armature.clone()
    mdp.randomize_joint_parameters(env, all_envs(env), friction_distribution_params=(0.0, 0.005), operation="abs",
                                   asset_cfg=entity(env))
    mdp.randomize_joint_parameters(env, all_envs(env), armature_distribution_params=(0.0, 2.0), operation="scale",
                                   asset_cfg=entity(env))
    assert ((robot.joint_friction >= 0.0) & (robot.joint_friction <= 0.005)).all()
    scale = robot.joint_armature / armature0
    assert ((scale >= 0.0) & (scale <= 2.0 + 1e-6)).all() and not torch.allclose(scale[0], scale[1])
    for field, values in ((solver.mjw_model.dof_frictionloss, env.sim.model.joint_friction),
                          (solver.mjw_model.dof_armature, env.sim.model.joint_armature)):
        mj, newton_values = mujoco_values_per_world(field, solver.mjc_dof_to_newton_dof, wp.to_torch(values))
        np.testing.assert_allclose(mj, newton_values, rtol=1e-6)


# -- external wrench ---------------------------------------------------------------------------------

def test_external_force_pushes_a_floating_robot_and_ends_with_the_episode():
    env = make_env(t1_implicit_actuators())
    robot = env.robot
    pose = robot.root_pose_w.clone()
    pose[:, 2] = 5.0  # far above the ground: only gravity and the pushed wrench act
    robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), all_envs(env))
    env.sim.forward()
    force_n = 50.0
    world_0 = torch.tensor([True, False, False])
    mdp.apply_external_force_torque(env, world_0, force_range=(force_n, force_n), torque_range=(0.0, 0.0),
                                    asset_cfg=entity(env, body_names="Trunk"))
    assert (robot.body_wrench_w[0, 0] == torch.tensor([force_n] * 3 + [0.0] * 3)).all()
    assert (robot.body_wrench_w[1:] == 0).all() and (robot.body_wrench_w[:, 1:] == 0).all()

    env_steps = 5
    settle(env, env_steps)
    # the whole robot's momentum changes by (F + M g) t whatever its joints do
    total_mass_kg = robot.body_mass.sum(dim=1)
    com_vel = (robot.body_mass.unsqueeze(-1) * robot.body_vel_w[..., :3]).sum(dim=1) / total_mass_kg.unsqueeze(-1)
    time_s = env_steps * STEP_DT_S
    expected = force_n / total_mass_kg[0] * time_s
    torch.testing.assert_close(com_vel[0], torch.tensor([expected, expected, expected - GRAVITY_MPS2 * time_s]),
                               atol=2e-3, rtol=1e-2)
    torch.testing.assert_close(com_vel[1], torch.tensor([0.0, 0.0, -GRAVITY_MPS2 * time_s]), atol=2e-3, rtol=1e-2)

    env.sim.reset_worlds(world_0)
    assert (robot.body_wrench_w == 0).all()


# -- body_acc_l2 -------------------------------------------------------------------------------------

def test_body_acc_l2_is_zero_without_velocity_change_and_g_squared_per_body_in_free_fall():
    env = make_env(t1_implicit_actuators())
    robot = env.robot
    pose = robot.root_pose_w.clone()
    pose[:, 2] = 5.0
    robot.write_root_state(pose, torch.zeros_like(robot.root_com_vel_w), all_envs(env))
    env.sim.forward()
    all_bodies = entity(env)
    robot.update_accelerations()  # right after a state write: no valid difference yet
    assert (mdp.body_acc_l2(env, all_bodies) == 0).all()
    robot.update_accelerations()  # velocity unchanged since the last update: at rest
    assert (mdp.body_acc_l2(env, all_bodies) == 0).all()

    settle(env, 1)
    robot.update_accelerations()
    falling = mdp.body_acc_l2(env, all_bodies)
    # every body falls with g (the PD-held joints barely move in 20 ms from rest)
    torch.testing.assert_close(falling, torch.full((NUM_ENVS,), robot.num_bodies * GRAVITY_MPS2**2), rtol=0.05,
                               atol=0.0)
    trunk = mdp.body_acc_l2(env, entity(env, body_names="Trunk"))
    torch.testing.assert_close(trunk, torch.full((NUM_ENVS,), GRAVITY_MPS2**2), rtol=0.05, atol=0.0)


# -- random upper-body actions -----------------------------------------------------------------------

def run_profile(profile: mdp.TrapezoidalProfile, dt_s: float, steps: int) -> torch.Tensor:
    positions = [profile.position()]
    for _ in range(steps):
        profile.advance(dt_s)
        positions.append(profile.position())
    return torch.stack(positions)  # (steps + 1, N, J)


@pytest.mark.parametrize("synchronize", [True, False])
def test_trapezoidal_profile_reaches_targets_within_velocity_and_acceleration_bounds(synchronize):
    torch.manual_seed(0)
    n, j = 64, 5
    cfg = mdp.TrapezoidalVelocityProfileCfg(acceleration_range=(1.0, 20.0), max_velocity_range=(10.0, 20.0),
                                            min_cruise_ratio=0.1, synchronize_joints=synchronize)
    velocity_limit = torch.full((n, j), 12.0)
    profile = mdp.TrapezoidalProfile(cfg, velocity_limit)
    start = torch.rand(n, j) * 4.0 - 2.0
    target = torch.rand(n, j) * 4.0 - 2.0
    target[0, 0] = start[0, 0]  # a joint that stays put
    profile.plan(start, target, torch.ones(n, dtype=torch.bool))
    # the profile's float32 positions: differences over 10 ms (the finest a 50 Hz step needs) measure the profile,
    # not rounding, to about 1e-3 in velocity and 0.3 rad/s² in acceleration
    dt_s = 1e-2
    steps = int(profile.duration_s.max() / dt_s) + 2
    path = run_profile(profile, dt_s, steps).double()

    assert profile.done.all()
    torch.testing.assert_close(path[-1].float(), target)
    torch.testing.assert_close(path[0].float(), start)
    velocity = path.diff(dim=0) / dt_s
    acceleration = velocity.diff(dim=0) / dt_s
    assert (velocity.abs() <= velocity_limit * (1 + 1e-6) + 1e-3).all()
    # a second difference straddling a phase change averages the two phases: within the bound as well
    assert (acceleration.abs() <= profile.acceleration * (1 + 1e-6) + 0.3).all()
    # the motion is monotonic (no overshoot) and each joint arrives by its duration
    direction = torch.sign(target - start)
    assert ((velocity * direction) >= -1e-3).all()
    if synchronize:
        assert (profile.duration_s == profile.duration_s[:, :1]).all()
    # at least min_cruise_ratio of the duration at cruise velocity: t_acc + t_dec <= (1 - r) T
    moving = profile.cruise_velocity > 0
    ramp_s = 2.0 * profile.cruise_velocity / profile.acceleration
    assert (ramp_s[moving] <= 0.9 * profile.duration_s[moving] + 1e-5).all()


def random_action_env() -> FakeEnv:
    env = FakeEnv(num_envs=4, joint_names=("leg", "arm_a", "arm_b"))
    env.step_dt = STEP_DT_S
    env.robot.joint_vel_limit = torch.full((4, 3), 30.0)
    return env


def test_random_action_is_training_only_and_moves_targets_within_limits():
    torch.manual_seed(0)
    env = random_action_env()
    actions_cfg = dataclasses.make_dataclass("Actions", [("joint_pos", object), ("random_pos", object)])(
        joint_pos=mdp.JointPositionActionCfg(joint_names=["leg"]),
        random_pos=mdp.RandomActionCfg(joint_names_exclude=["leg"], sample_range_s=(0.1, 0.5),
                                       velocity_profile_cfg=mdp.TrapezoidalVelocityProfileCfg(
                                           acceleration_range=(1.0, 20.0), max_velocity_range=(10.0, 20.0)),
                                       joint_pos_limits={"arm_a": (-0.5, 0.25)}))
    manager = ActionManager(actions_cfg, env)
    assert manager.total_action_dim == 1  # only the policy's leg joint
    term = manager.get_term("random_pos")
    assert term.joint_names == ["arm_a", "arm_b"]

    targets = []
    for _ in range(150):
        manager.process_action(torch.zeros(4, 1))
        manager.apply_action()
        targets.append(env.robot.joint_pos_target[:, 1:].clone())
    targets = torch.stack(targets)
    assert ((targets[..., 0] >= -0.5 - 1e-5) & (targets[..., 0] <= 0.25 + 1e-5)).all()
    assert ((targets[..., 1] >= -1.0 - 1e-5) & (targets[..., 1] <= 1.0 + 1e-5)).all()
    assert (targets.amax(dim=0) - targets.amin(dim=0) > 0.1).all()  # every env's arms moved
    assert not torch.allclose(targets[-1, 0], targets[-1, 1])  # envs draw their own targets
    step_velocity = targets.diff(dim=0).abs() / STEP_DT_S
    assert (step_velocity <= 20.0 * (1 + 1e-3)).all()

    reset = torch.tensor([True, False, False, False])
    manager.reset(reset)
    assert (term.processed_actions[0] == 0).all() and (term.processed_actions[1:] != 0).any()
