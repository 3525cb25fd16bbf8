"""HeightTracking-G1's reward, termination and curriculum terms against hand-computed values on scripted states
(fakes, no physics)."""

import math
import types

import pytest
import torch
from fakes import FakeEnv

from agile.tasks.height_tracking import mdp
from agile.rl_env.managers import CurrTerm, RewTerm, SceneEntityCfg

FEET = SceneEntityCfg("robot", body_names=["foot_l", "foot_r"], preserve_order=True)
BASE = SceneEntityCfg("robot", body_names=["base"])


def _resolved(cfg: SceneEntityCfg, env) -> SceneEntityCfg:
    cfg.resolve(env)
    return cfg


def _env_with_command(measured_m, target_m, lowest_m=-0.5):
    env = FakeEnv(num_envs=len(measured_m))
    target = torch.tensor(target_m)
    command = types.SimpleNamespace(measured_height_m=torch.tensor(measured_m), target_height_m=target,
                                    relaxation_intensity=(target / lowest_m).clamp(0.0, 1.0))
    env.command_manager = types.SimpleNamespace(get_term=lambda name: command)
    return env, command


def _quat_about(axis: str, angle_rad: float) -> torch.Tensor:
    s, c = math.sin(angle_rad / 2), math.cos(angle_rad / 2)
    return torch.tensor({"x": [s, 0.0, 0.0, c], "y": [0.0, s, 0.0, c]}[axis])


def test_track_height_command_exp_and_relaxation_penalty():
    env, _ = _env_with_command([0.5, 0.1], [0.8, -0.25])
    # exp(-0.3² / 0.5²) = exp(-0.36); exp(-0.35² / 0.5²) = exp(-0.49)
    value = mdp.track_height_command_exp(env, "height", std=0.5)
    assert value.tolist() == pytest.approx([math.exp(-0.36), math.exp(-0.49)], rel=1e-5)
    robot = env.robot
    robot.joint_pos[:] = torch.tensor([0.2, 0.0, -0.1])
    robot.applied_torque[:] = torch.tensor([10.0, 0.0, 0.0])
    # env 0: command >= 0, no penalty; env 1: intensity 0.25 / 0.5 = 0.5: 0.5 · 2 · (0.04 + 0.01) + 1e-3 · 100
    penalty = mdp.relaxation_penalty(env, "height", _resolved(SceneEntityCfg("robot"), env), pos_weight=2.0)
    assert penalty.tolist() == pytest.approx([0.0, 0.05 + 0.1], rel=1e-5)


def test_moving_if_tracking_only_near_the_target():
    env, _ = _env_with_command([0.5, 0.5], [0.55, 0.8])
    env.robot.body_vel_w = torch.zeros(2, 3, 6)
    env.robot.body_vel_w[:, 0, :3] = torch.tensor([0.3, 0.4, 0.0])  # 0.5 m/s
    env.robot.body_vel_w[:, 1, 3:] = torch.tensor([0.0, 0.0, 1.5])  # 1.5 rad/s
    # env 0 within 0.1 m: mean |v| over 3 bodies 0.5/3, mean |ω| 1.5/3, weighted 1 and 2; env 1 0.3 m away: 0
    value = mdp.moving_if_tracking(env, "height", error_threshold_m=0.1,
                                   asset_cfg=_resolved(SceneEntityCfg("robot"), env), weight_ang=2.0)
    assert value.tolist() == pytest.approx([0.5 / 3 + 2.0 * 0.5, 0.0], rel=1e-5)


def test_tilt_terms_on_known_rotations():
    env = FakeEnv(num_envs=3)
    poses = env.robot.body_pose_w
    poses[0, 0, 3:7] = _quat_about("y", math.radians(30))  # pitched forward 30° (z axis toward +x)
    poses[1, 0, 3:7] = _quat_about("x", math.radians(-20))  # rolled 20° to the right
    poses[2, 0, 3:7] = _quat_about("y", math.radians(150))  # nearly upside down
    base = _resolved(BASE, env)
    # severely tilted past 135°: only env 2
    assert mdp.severely_tilted_penalty(env, base, math.radians(135)).tolist() == [0.0, 0.0, 1.0]
    # forward pitch: gravity along body x is sin(30°) = 0.5 forward; l2 0.25; env 2 (150°): sin 150° = 0.5 too
    pitch = mdp.body_orientation_penalty(env, base, axis="pitch", direction="forward", kernel="l2")
    assert pitch.tolist() == pytest.approx([0.25, 0.0, 0.25], abs=1e-6)
    assert mdp.body_orientation_penalty(env, base, axis="pitch", direction="backward").tolist() == \
        pytest.approx([0.0, 0.0, 0.0], abs=1e-6)
    roll = mdp.body_orientation_penalty(env, base, axis="roll", direction="both", kernel="l1")
    assert roll.tolist() == pytest.approx([0.0, math.sin(math.radians(20)), 0.0], abs=1e-6)
    with pytest.raises(ValueError, match="axis must be one of"):
        mdp.body_orientation_penalty(env, base, axis="yaw")


def test_upright_orientation_after_standing_waits_for_the_standing_time():
    env = FakeEnv(num_envs=2)
    env.step_dt = 0.5
    env.robot.root_pos_w[:, 2] = torch.tensor([0.6, 0.2])  # env 0 up (> 0.4 m), env 1 down
    env.robot.body_pose_w[:, 0, 3:7] = _quat_about("x", 0.3)
    term = mdp.upright_orientation_after_standing(
        RewTerm(func=mdp.upright_orientation_after_standing, weight=-1.0, params={}), env)
    params = {"min_height_m": 0.4, "min_standing_duration_s": 1.0, "asset_cfg": _resolved(BASE, env)}
    assert term(env, **params).tolist() == [0.0, 0.0]  # 0.5 s standing
    assert term(env, **params).tolist() == pytest.approx([0.3, 0.0], abs=1e-6)  # 1 s: the tilt, 0.3 rad
    term.reset(torch.tensor([True, False]))
    assert term(env, **params).tolist() == [0.0, 0.0]


def test_feet_distance_3d_asymmetric_and_ramped():
    env = FakeEnv(num_envs=3)
    env.step_dt = 0.02
    feet = env.robot.body_pose_w
    feet[:, 2, 1] = torch.tensor([0.1, 0.35, 0.5])  # foot_r at y; foot_l at 0: distances 0.1, 0.35, 0.5 m
    env.episode_length_buf[:] = torch.tensor([100, 100, 100])  # 2 s: ramp (2 - 1) / 2 = 0.5
    params = {"ref_distance_m": 0.2, "asset_cfg": _resolved(FEET, env), "norm": "l2", "error_threshold_m": 0.2,
              "close_multiplier": 5.0, "episode_delay_s": 1.0, "episode_ramp_s": 2.0}
    # too close: (-0.1·5)² = 0.25; 0.15 too far is within the 0.2 dead zone: 0; 0.3 too far: 0.09; all × 0.5
    assert mdp.feet_distance_3d(env, **params).tolist() == pytest.approx([0.125, 0.0, 0.045], abs=1e-6)
    env.episode_length_buf[:] = 25  # 0.5 s: still in the delay
    assert not mdp.feet_distance_3d(env, **params).any()


def test_contact_and_speed_terms():
    env = FakeEnv(num_envs=2)
    sensor = types.SimpleNamespace(net_forces_w=torch.zeros(2, 3, 3), net_forces_w_history=torch.zeros(2, 3, 3, 3),
                                   lin_vel_w_history=torch.zeros(2, 3, 3, 3))
    env.scene["contact_forces"] = sensor
    sensor.net_forces_w[0, 1, 2] = 5.0  # env 0: a foot touches; env 1: nothing above 1 N
    sensor.net_forces_w[1, 2, 2] = 0.5
    all_bodies = SceneEntityCfg("contact_forces", body_names=".*")
    all_bodies.body_ids = [0, 1, 2]
    assert mdp.completely_airborne(env, all_bodies, force_threshold_n=1.0).tolist() == [0.0, 1.0]
    env.robot.body_vel_w = torch.zeros(2, 3, 6)
    env.robot.body_vel_w[0, :, 0] = torch.tensor([0.2, 0.5, 1.3])
    # (0.5 - 0.3)² + (1.3 - 0.3)² = 1.04 (0.2 m/s is inside the dead zone)
    speed = mdp.bodies_lin_vel_l2(env, _resolved(SceneEntityCfg("robot", body_names=".*"), env), threshold_mps=0.3)
    assert speed.tolist() == pytest.approx([1.04, 0.0])
    # impact: body 0 of env 0 touched 20 N two physics steps ago and moves at 2 m/s now: l2 4
    sensor.net_forces_w_history[0, 2, 0, 2] = 20.0
    sensor.lin_vel_w_history[0, 0, 0] = torch.tensor([0.0, 0.0, -2.0])
    sensor.lin_vel_w_history[1, 0, 0] = torch.tensor([0.0, 0.0, -3.0])  # env 1 moves but touches nothing
    assert mdp.impact_velocity(env, all_bodies, 10.0, kernel="l2").tolist() == pytest.approx([4.0, 0.0])


def test_invalid_state_bounds_and_nan():
    env = FakeEnv(num_envs=4)
    robot = env.robot
    robot.joint_vel = torch.zeros(4, 3)
    robot.root_lin_vel_w, robot.root_ang_vel_w = torch.zeros(4, 3), torch.zeros(4, 3)
    robot.joint_vel[1, 2] = -101.0  # too fast a joint
    robot.root_pos_w[2, 2] = 5.5  # too high above the env origin
    robot.root_ang_vel_w[3, 0] = float("nan")
    assert mdp.invalid_state(env).tolist() == [False, True, True, True]


class _Action:
    def __init__(self):
        self.scale = None

    def scale_forces(self, scale):
        self.scale = scale.clone()


def test_adaptive_force_decay_against_hand_computed_steps():
    env = FakeEnv(num_envs=2)
    command = types.SimpleNamespace(metrics={"height_error_m": torch.tensor([0.05, 0.15])})
    action = _Action()
    env.command_manager = types.SimpleNamespace(get_term=lambda name: command)
    env.action_manager = types.SimpleNamespace(get_term=lambda name: action)
    params = {"action_name": "lift", "command_name": "height", "threshold_m": 0.1, "ema_alpha": 0.5, "decay": 0.5,
              "disable_below": 0.2}
    term = mdp.adaptive_force_decay(CurrTerm(func=mdp.adaptive_force_decay, params=params), env)
    both, first, nobody = torch.tensor([True, True]), torch.tensor([True, False]), torch.tensor([False, False])
    # EMA from 1 m: both end (mean 0.1): 0.55; then env 0 alone (0.05): 0.3, 0.175, 0.1125, 0.08125 (< 0.1: halve)
    for mask, ema, scale in ((both, 0.55, 1.0), (first, 0.3, 1.0), (first, 0.175, 1.0), (first, 0.1125, 1.0),
                             (first, 0.08125, 0.5), (nobody, 0.08125, 0.5), (first, 0.065625, 0.25),
                             (first, 0.0578125, 0.0)):  # 0.125 < 0.2: off
        value = term(env, mask, **params)
        assert term.error_ema_m.item() == pytest.approx(ema) and value.item() == pytest.approx(scale)
        assert action.scale.item() == pytest.approx(scale)
    command.metrics["height_error_m"].fill_(1.0)
    assert term(env, both, **params).item() == 0.0  # never rises again


def test_reward_weight_ramps_after_its_prerequisite():
    env = FakeEnv(num_envs=2)
    weights = {"torso_slam": torch.tensor(-5.0)}
    env.reward_manager = types.SimpleNamespace(
        weights=weights, get_term_cfg=lambda name: types.SimpleNamespace(weight=-5.0),
        set_term_weight=lambda name, w: weights[name].copy_(w))
    env.curriculum_manager = types.SimpleNamespace(term_cfgs={"terrain_levels": None}, active_terms=["terrain_levels"],
                                                   state={"terrain_levels": torch.tensor(3.0)})
    params = {"reward_name": "torso_slam", "prerequisite_curriculum": "terrain_levels", "prerequisite_threshold": 4.0,
              "delay_steps": 10, "num_steps": 100, "terminal_weight": -255.0}
    term = mdp.update_reward_weight_after_curriculum(
        CurrTerm(func=mdp.update_reward_weight_after_curriculum, params=params), env)
    nobody = torch.zeros(2, dtype=torch.bool)
    env.common_step_counter = 50
    assert term(env, nobody, **params).item() == -5.0  # terrain level 3 < 4: not yet
    env.curriculum_manager.state["terrain_levels"] = torch.tensor(4.2)
    assert term(env, nobody, **params).item() == -5.0 and term.trigger_step.item() == 50
    env.common_step_counter = 60 + 40  # 40 of 100 ramp steps after the 10-step delay: -5 + 0.4·(-250) = -105
    assert term(env, nobody, **params).item() == pytest.approx(-105.0) and weights["torso_slam"].item() == -105.0
    env.curriculum_manager.state["terrain_levels"] = torch.tensor(1.0)  # the trigger holds once met
    env.common_step_counter = 500
    assert term(env, nobody, **params).item() == pytest.approx(-255.0)
    with pytest.raises(ValueError, match="no curriculum term 'terrain'"):
        term(env, nobody, **{**params, "prerequisite_curriculum": "terrain"})
