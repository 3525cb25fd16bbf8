"""Terms of the velocity-and-height tasks with hand-computed values: the command, the curricula, the foot scans,
link distances, the rewards, the mirror of the new observations and the upper body's random targets (the harness
wrench and the env configs on a built env: tests/test_velocity_height_envs.py)."""

import math

import pytest
import torch
from fakes import FakeEnv

from agile.tasks.velocity import mdp
from agile.rl_env.managers import CurrTerm, EventTerm, SceneEntityCfg
from agile.rl_env.mdp.symmetry import feet_scan_mirror
from agile.sim.height_scanner import grid_pattern


def _entity(env, **kwargs):
    cfg = SceneEntityCfg("robot", **kwargs)
    cfg.resolve(env)
    return cfg


def _command(env, **cfg_kwargs):
    cfg = mdp.UniformVelocityBaseHeightCommandCfg(**cfg_kwargs)
    return mdp.UniformVelocityBaseHeightCommand(cfg, env)


# -- command -----------------------------------------------------------------------------------------------

def test_height_command_ranges_and_standing_share():
    torch.manual_seed(0)
    env = FakeEnv(num_envs=4000)
    term = _command(env, rel_standing_envs=0.25, min_vel_norm=0.0)
    term.reset(torch.ones(4000, dtype=torch.bool))
    command = term.command
    assert command.shape == (4000, 4)
    assert (command[:, :2].abs() <= 0.5).all() and (command[:, 2].abs() <= 1.0).all()
    standing = term.is_standing_env
    assert 0.22 < standing.float().mean().item() < 0.28
    assert (command[standing, :3] == 0.0).all() and (command[~standing, :3] != 0.0).any(dim=1).all()
    # standing envs crouch anywhere in 0.4-0.72 m, walking envs walk at the default height
    assert (command[standing, 3] >= 0.4).all() and (command[standing, 3] <= 0.72).all()
    assert command[standing, 3].min() < 0.45 and command[standing, 3].max() > 0.67
    assert (command[~standing, 3] == 0.72).all()


def test_min_vel_norm_zeroes_slow_draws_and_min_walk_height_bounds_walking():
    torch.manual_seed(0)
    env = FakeEnv(num_envs=2000)
    term = _command(env, rel_standing_envs=0.0, min_vel_norm=0.3, random_height_during_walking=True,
                    min_walk_height_m=0.55)
    term.reset(torch.ones(2000, dtype=torch.bool))
    speed = torch.linalg.norm(term.command[:, :3], dim=1)
    assert ((speed == 0.0) | (speed >= 0.3)).all() and (speed == 0.0).any()
    walking = ~term.is_standing_env
    assert torch.equal(walking, speed > 0.0)
    heights = term.command[walking, 3]
    assert (heights >= 0.55).all() and (heights <= 0.72).all() and heights.min() < 0.58


def test_height_command_ema_and_reset():
    env = FakeEnv(num_envs=1)
    term = _command(env, ema_smoothing=0.5)
    term.time_left_s[:] = 100.0  # no resampling during the test
    term.height_command_m[:] = 0.72
    term.height_target_m[:] = 0.4
    term.compute(0.02)
    assert term.command[0, 3].item() == pytest.approx(0.56)  # 0.5·0.72 + 0.5·0.4
    term.compute(0.02)
    assert term.command[0, 3].item() == pytest.approx(0.48)
    term.reset(torch.ones(1, dtype=torch.bool))  # a new episode starts at its drawn height
    assert term.command[0, 3].item() == pytest.approx(term.height_target_m[0].item())


def test_heading_command_turns_towards_the_target():
    env = FakeEnv(num_envs=2)
    term = _command(env, heading_command=True, rel_heading_envs=1.0, heading_control_stiffness=0.5,
                    rel_standing_envs=0.0, min_vel_norm=0.0)
    term.reset(torch.ones(2, dtype=torch.bool))
    term.heading_target_rad[:] = torch.tensor([1.0, 3.0])
    env.robot.heading_w[:] = torch.tensor([0.0, -3.0])  # env 1: the short way round is -0.28 rad
    term._update_command()
    assert term.command[:, 2].tolist() == pytest.approx([0.5, 0.5 * (6.0 - 2 * math.pi)], rel=1e-5)


@pytest.mark.parametrize("bad", [dict(ranges=mdp.VelocityHeightRangesCfg(base_height_m=(0.72, 0.4))),
                                 dict(ema_smoothing=0.0), dict(rel_standing_envs=1.5),
                                 dict(min_walk_height_m=0.3), dict(default_height_m=0.45)])
def test_height_command_rejects_bad_settings(bad):
    with pytest.raises(ValueError):
        _command(FakeEnv(num_envs=1), **bad)


# -- curricula ---------------------------------------------------------------------------------------------

class _Harness:
    def __init__(self):
        self.scale = None

    def scale_forces(self, scale):
        self.scale = float(scale)


class _Terms:
    def __init__(self, **terms):
        self.terms = terms

    def get_term(self, name):
        return self.terms[name]


def test_remove_harness_is_linear_then_zero():
    env = FakeEnv(num_envs=1)
    harness = _Harness()
    env.action_manager = _Terms(harness=harness)
    for step, expected in ((0, 1.0), (100, 1.0), (125, 0.75), (200, 0.0), (1000, 0.0)):
        env.common_step_counter = torch.tensor(step)
        value = mdp.remove_harness(env, None, harness_action_name="harness", start_step=100, num_steps=100)
        assert harness.scale == pytest.approx(expected) and value.item() == pytest.approx(expected)


class _EventManager:
    def __init__(self, term_cfgs):
        self.term_cfgs = term_cfgs


class _Terminations:
    def __init__(self, time_outs):
        self.time_outs = time_outs


def test_pushing_curriculum_grows_while_few_fall_and_shrinks_while_many_do():
    env = FakeEnv(num_envs=4)
    push = EventTerm(func=mdp.push_by_setting_velocity, mode="interval", interval_range_s=(2.0, 5.0),
                     params={"velocity_range": {"x": (-0.2, 0.2), "yaw": (-0.05, 0.05)}})
    env.event_manager = _EventManager({"push_robot": push})
    params = {"max_vel": {"x": 0.20003}, "min_vel": {"x": 0.1}, "fall_ratio_thresholds": (0.1, 0.3)}
    term = mdp.pushing_curriculum(CurrTerm(func=mdp.pushing_curriculum, params=params), env)
    assert push.params["velocity_scale"] is term.scale
    everyone = torch.ones(4, dtype=torch.bool)
    env.termination_manager = _Terminations(torch.ones(4, dtype=torch.bool))  # all timed out: none fell
    assert term(env, everyone, **params).item() == pytest.approx(0.2 * 1.0001)
    assert term.scale[5].item() == 1.0  # yaw has no max_vel: AGILE leaves it as configured
    assert term(env, everyone, **params).item() == pytest.approx(0.20003)  # capped at max_vel
    assert term(env, torch.zeros(4, dtype=torch.bool), **params).item() == pytest.approx(0.20003)  # none finished
    env.termination_manager = _Terminations(torch.tensor([True, False, False, False]))  # 3 of 4 fell
    assert term(env, everyone, **params).item() == pytest.approx(0.20003 * 0.9999)
    env.termination_manager = _Terminations(torch.tensor([True, True, True, False]))  # 1 of 4: in between
    assert term(env, everyone, **params).item() == pytest.approx(0.20003 * 0.9999)


# -- observations and terminations -------------------------------------------------------------------------

class _Scanner:
    def __init__(self, pos_w, hit_z_m, ray_offsets_b=None):
        self.pos_w, self.hit_z_m, self.ray_offsets_b = pos_w, hit_z_m, ray_offsets_b


def test_height_scan_feet_and_base_height():
    env = FakeEnv(num_envs=1)
    env.scene["left"] = _Scanner(torch.tensor([[0.0, 0.1, 0.30]]), torch.tensor([[0.0, 0.1, -0.2]]))
    env.scene["right"] = _Scanner(torch.tensor([[0.0, -0.1, 0.05]]), torch.tensor([[0.05, 0.0, 0.1]]))
    scan = mdp.height_scan_feet(env, left_sensor_name="left", right_sensor_name="right")
    assert scan.tolist()[0] == pytest.approx([0.3, 0.2, 0.5, 0.0, 0.05, -0.05])
    env.robot.root_pos_w[:, 2] = 0.8
    height = mdp.base_height_from_sensor(env, sensor_name="left", asset_cfg=_entity(env))
    assert height.shape == (1, 1) and height.item() == pytest.approx(0.8 + 0.1 / 3)


def test_feet_scan_mirror_swaps_feet_and_reflects_y():
    offsets = grid_pattern((0.3, 0.2), 0.05, "cpu") + torch.tensor([0.05, 0.0])  # 7 x 5, x fastest
    perm, sign = feet_scan_mirror(offsets, offsets.clone(), "test")
    assert len(perm) == 70 and sign == [1.0] * 70
    assert perm[0] == 35 + 28  # left (x0, y=-0.1) -> right (x0, y=+0.1)
    assert perm[35 + 16] == 16  # right (x2, y=0) -> left (x2, y=0)
    assert [perm[p] for p in perm] == list(range(70))
    with pytest.raises(ValueError, match="mirror images"):
        feet_scan_mirror(offsets, offsets + torch.tensor([0.0, 0.02]), "test")


def test_link_distance():
    env = FakeEnv(num_envs=3)
    env.robot.body_pose_w[:, 1, :3] = torch.tensor([[0.0, 0.025, 0.0], [0.0, 0.15, 0.0], [0.0, 0.3, 0.0]])
    env.robot.body_pose_w[:, 2, :3] = torch.tensor([[0.0, -0.025, 0.0], [0.0, -0.15, 0.0], [0.0, -0.3, 0.0]])
    feet = _entity(env, body_names=["foot_l", "foot_r"])
    too_close_or_far = mdp.link_distance(env, min_distance_m=0.1, max_distance_m=0.5, asset_cfg=feet)
    assert too_close_or_far.tolist() == [True, False, True]
    assert mdp.link_distance(env, min_distance_m=0.1, asset_cfg=feet).tolist() == [True, False, False]
    with pytest.raises(ValueError, match="two bodies"):
        mdp.link_distance(env, min_distance_m=0.1, asset_cfg=_entity(env, body_names=".*"))


# -- rewards -----------------------------------------------------------------------------------------------

class _CommandTerm:
    def __init__(self, command):
        self.command = command
        self.cfg = mdp.UniformVelocityBaseHeightCommandCfg()  # ranges ±0.5 m/s

    def get_term(self, name):
        return self

    def get_command(self, name):
        return self.command


class _ContactSensor:
    def __init__(self, forces_z):
        self.net_forces_w = torch.zeros(*forces_z.shape, 3)
        self.net_forces_w[..., 2] = forces_z

    def find_bodies(self, exprs, preserve_order=False):
        return list(range(self.net_forces_w.shape[1])), []


def _moving_env(command):
    env = FakeEnv(num_envs=command.shape[0])
    env.command_manager = _CommandTerm(command)
    env.robot.root_lin_vel_w = torch.zeros(env.num_envs, 3)
    env.robot.root_ang_vel_w = torch.zeros(env.num_envs, 3)
    return env


def test_velocity_tracking_in_the_yaw_frame():
    env = _moving_env(torch.tensor([[0.3, 0.0, 0.5, 0.7], [0.0, 0.0, 0.0, 0.7]]))
    env.robot.heading_w[:] = math.pi / 2
    env.robot.root_lin_vel_w[:] = torch.tensor([0.0, 0.3, 0.0])  # forward, for a robot facing +y
    weight = 1.0 + (0.3 - 0.01) / (math.hypot(0.5, 0.5) - 0.01)
    value = mdp.track_lin_vel_xy_yaw_frame_exp_weighted(env, std=0.2, command_name="c", asset_cfg=_entity(env))
    assert value.tolist() == pytest.approx([weight, math.exp(-0.09 / 0.04)], rel=1e-5)
    value = mdp.track_lin_vel_xy_yaw_frame_exp(env, std=0.5, command_name="c", asset_cfg=_entity(env))
    assert value.tolist() == pytest.approx([1.0, math.exp(-0.09 / 0.25)], rel=1e-5)
    env.robot.root_ang_vel_w[:, 2] = 0.3
    value = mdp.track_ang_vel_z_world_exp(env, std=0.2, command_name="c", asset_cfg=_entity(env))
    assert value.tolist() == pytest.approx([math.exp(-0.04 / 0.04), math.exp(-0.09 / 0.04)], rel=1e-5)


def test_base_height_tracking_above_the_terrain():
    env = _moving_env(torch.tensor([[0.0, 0.0, 0.0, 0.6]]))
    env.scene["base_ray"] = _Scanner(None, torch.tensor([[0.1]]))
    env.robot.root_pos_w[:, 2] = 0.6  # 0.5 m above the terrain
    value = mdp.track_base_height_exp_smooth(env, std=0.2, command_name="c", sensor_name="base_ray",
                                             asset_cfg=_entity(env))
    assert value.item() == pytest.approx(math.exp(-0.01 / 0.04), rel=1e-5)
    assert mdp.base_height_in_threshold(env, threshold_m=0.11, command_name="c", sensor_name="base_ray",
                                        asset_cfg=_entity(env)).item() == 1.0
    assert mdp.base_height_in_threshold(env, threshold_m=0.09, command_name="c", sensor_name="base_ray",
                                        asset_cfg=_entity(env)).item() == 0.0


def test_null_command_rewards():
    env = _moving_env(torch.tensor([[0.0, 0.0, 0.0, 0.5], [0.2, 0.0, 0.0, 0.72]]))  # stand, walk
    robot = env.robot
    robot.root_lin_vel_b[:] = torch.tensor([0.0, 0.0, 0.2])
    robot.root_ang_vel_b[:] = torch.tensor([0.1, 0.1, 5.0])
    value = mdp.no_undesired_base_velocity_exp_if_null_cmd(env, std=0.1, command_name="c", asset_cfg=_entity(env))
    assert value.tolist() == pytest.approx([math.exp(-(0.1 * 0.04 + 0.02) / 0.01), math.exp(-(0.04 + 0.02) / 0.01)],
                                           rel=1e-5)
    value = mdp.no_undesired_base_velocity_exp(env, std=0.1, asset_cfg=_entity(env))  # whatever the command
    assert value.tolist() == pytest.approx([math.exp(-(0.04 + 0.02) / 0.01)] * 2, rel=1e-5)
    env.scene["contact"] = _ContactSensor(torch.tensor([[100.0, 300.0], [100.0, 300.0]]))
    feet = SceneEntityCfg("contact", body_names=".*")
    feet.body_ids = slice(None)
    assert mdp.equal_foot_force_if_null_cmd(env, command_name="c", sensor_cfg=feet).tolist() == \
        pytest.approx([0.5, 0.0])  # 1 - mean |F - 200| / 200 while standing
    assert mdp.stand_with_both_feet_if_null_cmd(env, threshold_n=1.0, command_name="c", sensor_cfg=feet).tolist() == \
        pytest.approx([0.5, 0.0])
    env.scene["contact"] = _ContactSensor(torch.tensor([[0.0, 400.0], [0.0, 400.0]]))  # one foot up
    assert mdp.stand_with_both_feet_if_null_cmd(env, threshold_n=1.0, command_name="c", sensor_cfg=feet).tolist() == \
        pytest.approx([-1.0, 0.0])

    robot.applied_torque[:] = torch.tensor([10.0, -20.0, 0.0])
    robot.joint_effort_limit = torch.tensor([20.0, 40.0, 50.0]).repeat(2, 1)
    rms = math.sqrt((0.25 + 0.25 + 0.0) / 3)
    value = mdp.relax_if_null_cmd_exp(env, std=0.25, command_name="c", asset_cfg=_entity(env))
    assert value.tolist() == pytest.approx([math.exp(-(rms / 0.25) ** 2), 0.0], rel=1e-4)
    assert mdp.relax_if_null_cmd(env, command_name="c", asset_cfg=_entity(env)).tolist() == pytest.approx([500.0, 0.0])
    robot.projected_gravity_b[:] = torch.tensor([0.6, 0.0, -0.8])
    assert mdp.flat_orientation_if_null_cmd(env, command_name="c", asset_cfg=_entity(env)).tolist() == \
        pytest.approx([0.36, 0.0])


def test_joint_deviation_l2():
    env = FakeEnv(num_envs=1)
    env.robot.joint_pos[:] = torch.tensor([0.5, -0.2, 0.3])
    env.robot.default_joint_pos[:] = torch.tensor([0.1, 0.1, 0.3])
    assert mdp.joint_deviation_l2(env, asset_cfg=_entity(env, joint_names=["a", "b"])).item() == \
        pytest.approx(0.16 + 0.09)


def test_random_upper_body_targets_return_to_default_while_walking():
    torch.manual_seed(0)
    env = FakeEnv(num_envs=2)
    env.step_dt = 0.02
    env.command_manager = _CommandTerm(torch.tensor([[0.3, 0.0, 0.0, 0.72], [0.0, 0.0, 0.0, 0.5]]))  # walk, stand
    env.robot.default_joint_pos[:] = 0.2
    cfg = mdp.RandomActionCfg(joint_names=[".*"], sample_range_s=(0.02, 0.02), no_random_when_walking=True,
                              command_name="c")
    term = mdp.RandomPositionAction(cfg, env)
    for _ in range(200):  # many short motions, each to a new target once the last one is done
        term.process_actions(torch.zeros(2, 0))
        assert torch.allclose(term.processed_actions[0], torch.full((3,), 0.2))
    assert not torch.allclose(term.processed_actions[1], torch.full((3,), 0.2))
