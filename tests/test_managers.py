"""Managers on a fake env, with hand-computed expectations."""

import pytest
import torch
from fakes import FakeEnv

from agile.rl_env import mdp
from agile.rl_env.managers import (ActionManager, CommandManager, CurriculumManager, CurrTerm, DoneTerm, EventManager,
                                   EventTerm, ObsGroup, ObservationManager, ObsTerm, RewardManager, RewTerm,
                                   TerminationManager, Unoise)
from agile.utils.config import ConfigError, configclass


def const(env, value: float):
    return torch.full((env.num_envs,), value)


def const_vec(env, value: float, dim: int = 2):
    return torch.full((env.num_envs, dim), value)


def counter(env):
    return env.counter.clone().unsqueeze(-1).float()


def test_reward_manager_weights_dt_and_episode_sums():
    @configclass
    class Rewards:
        alive = RewTerm(func=const, weight=2.0, params={"value": 1.0})
        cost = RewTerm(func=const, weight=-1.0, params={"value": 3.0})
        off = RewTerm(func=const, weight=0.0, params={"value": 100.0})

    env = FakeEnv(num_envs=2)
    manager = RewardManager(Rewards(), env)
    dt = 0.02
    for _ in range(3):
        reward = manager.compute(dt)
    assert torch.allclose(reward, torch.full((2,), (2.0 * 1.0 - 1.0 * 3.0) * dt))
    assert torch.allclose(manager.episode_sums["alive"], torch.full((2,), 3 * 2.0 * dt))
    assert torch.allclose(manager.episode_sums["off"], torch.zeros(2))
    log = manager.reset(torch.tensor([True, False]))
    assert log["Episode_Reward/cost"].item() == pytest.approx(3 * -3.0 * dt / env.max_episode_length_s)
    assert manager.episode_sums["alive"].tolist() == pytest.approx([0.0, 3 * 2.0 * dt])


def test_reward_params_are_checked_against_the_function():
    @configclass
    class Rewards:
        bad = RewTerm(func=const, weight=1.0, params={"valeu": 1.0})

    with pytest.raises(ConfigError, match="reward term 'bad'.*no parameter 'valeu'"):
        RewardManager(Rewards(), FakeEnv())


def test_termination_manager_keeps_time_outs_apart():
    def by_env(env, which):
        return torch.tensor([i == which for i in range(env.num_envs)])

    @configclass
    class Terms:
        time_out = DoneTerm(func=by_env, params={"which": 0}, time_out=True)
        fall = DoneTerm(func=by_env, params={"which": 1})

    env = FakeEnv(num_envs=3)
    manager = TerminationManager(Terms(), env)
    dones = manager.compute()
    assert dones.tolist() == [True, True, False]
    assert manager.time_outs.tolist() == [True, False, False]
    assert manager.terminated.tolist() == [False, True, False]
    log = manager.reset(torch.tensor([True, True, False]))
    assert log["Episode_Termination/fall"].item() == pytest.approx(0.5)


def test_observation_noise_then_clip_then_scale():
    @configclass
    class Policy(ObsGroup):
        enable_corruption = True
        x = ObsTerm(func=const_vec, params={"value": 1.0}, noise=Unoise(0.5, 0.5), clip=(-1.0, 1.2), scale=2.0)

    @configclass
    class Obs:
        policy = Policy()

    obs = ObservationManager(Obs(), FakeEnv()).compute()
    assert torch.allclose(obs["policy"], torch.full((2, 2), 2.4))


def test_observation_history_oldest_first_and_refilled_at_reset():
    @configclass
    class Policy(ObsGroup):
        concatenate_terms = False
        history_length = 3
        count = ObsTerm(func=counter)

    @configclass
    class Obs:
        policy = Policy()

    env = FakeEnv(num_envs=2)
    env.counter = torch.tensor([1.0, 1.0])
    manager = ObservationManager(Obs(), env)  # builds with one evaluation of each term
    assert manager.group_dims == {"policy": 3}
    for value in (1.0, 2.0, 3.0, 4.0):
        env.counter = torch.tensor([value, value])
        obs = manager.compute()
    assert obs["policy"]["count"].tolist() == [[2.0, 3.0, 4.0], [2.0, 3.0, 4.0]]
    manager.reset(torch.tensor([True, False]))
    env.counter = torch.tensor([9.0, 5.0])
    obs = manager.compute()
    assert obs["policy"]["count"].tolist() == [[9.0, 9.0, 9.0], [3.0, 4.0, 5.0]]


def test_joint_position_action_scale_offset_clip():
    @configclass
    class Actions:
        joint_pos = mdp.JointPositionActionCfg(joint_names=["a", "c"], scale={"a": 0.5, "c": 2.0},
                                               use_default_offset=True, clip=(-1.0, 1.0))

    env = FakeEnv(num_envs=1)
    env.robot.default_joint_pos[:] = torch.tensor([0.1, 0.2, 0.3])
    manager = ActionManager(Actions(), env)
    assert manager.total_action_dim == 2
    manager.process_action(torch.tensor([[1.0, 1.0]]))
    manager.apply_action()
    # a: 1*0.5 + 0.1 = 0.6; c: 1*2 + 0.3 = 2.3 -> clipped to 1.0; b untouched
    assert env.robot.joint_pos_target[0].tolist() == pytest.approx([0.6, 0.0, 1.0])
    with pytest.raises(ValueError, match="action shape"):
        manager.process_action(torch.zeros(1, 3))


def test_interval_event_fires_per_env_timer():
    calls = []

    def record(env, env_mask):
        calls.append(env_mask.clone())

    @configclass
    class Events:
        tick = EventTerm(func=record, mode="interval", interval_range_s=(0.1, 0.1))

    env = FakeEnv(num_envs=2)
    manager = EventManager(Events(), env)
    for _ in range(5):
        manager.apply("interval", dt=0.0201)
    assert [c.any().item() for c in calls] == [False, False, False, False, True]


def test_interval_event_without_interval_is_a_config_error():
    @configclass
    class Events:
        tick = EventTerm(func=lambda env, env_mask: None, mode="interval")

    with pytest.raises(ConfigError, match="event term 'tick': interval mode needs interval_range_s"):
        EventManager(Events(), FakeEnv())


def test_velocity_command_standing_share_and_min_norm():
    @configclass
    class Commands:
        base_velocity = mdp.UniformNullVelocityCommandCfg(
            rel_standing_envs=0.5, min_vel_norm=0.3,
            ranges=mdp.VelocityRangesCfg(lin_vel_x=(-1.0, 1.0), lin_vel_y=(-1.0, 1.0), ang_vel_z=(-1.0, 1.0)))

    torch.manual_seed(0)
    env = FakeEnv(num_envs=4000)
    manager = CommandManager(Commands(), env)
    manager.reset(torch.ones(4000, dtype=torch.bool))
    cmd = manager.get_command("base_velocity")
    norm = cmd.norm(dim=1)
    standing = norm == 0
    assert ((norm >= 0.3) | standing).all()
    assert 0.45 < standing.float().mean().item() < 0.6  # 50% drawn standing, plus the few below 0.3 m/s
    term = manager.get_term("base_velocity")
    assert ((term.time_left_s >= 8.0) & (term.time_left_s <= 12.0)).all()


def test_reward_weight_ramp_linear_and_log():
    @configclass
    class Rewards:
        rate = RewTerm(func=const, weight=-0.5, params={"value": 1.0})
        rate2 = RewTerm(func=const, weight=-0.1, params={"value": 1.0})

    @configclass
    class Curriculum:
        lin = CurrTerm(func=mdp.update_reward_weight_step,
                       params={"reward_name": "rate", "start_step": 10, "num_steps": 20, "terminal_weight": -2.0})
        log = CurrTerm(func=mdp.update_reward_weight_step,
                       params={"reward_name": "rate2", "start_step": 0, "num_steps": 10, "terminal_weight": -10.0,
                               "use_log_space": True})

    env = FakeEnv()
    env.reward_manager = RewardManager(Rewards(), env)
    curriculum = CurriculumManager(Curriculum(), env)
    mask = torch.zeros(2, dtype=torch.bool)
    env.common_step_counter = 5
    curriculum.compute(mask)
    assert env.reward_manager.weights["rate"].item() == pytest.approx(-0.5)
    assert env.reward_manager.weights["rate2"].item() == pytest.approx(-1.0)  # halfway in log space
    env.common_step_counter = 20
    log = curriculum.compute(mask)
    assert env.reward_manager.weights["rate"].item() == pytest.approx(-1.25)
    assert log["Curriculum/lin"].item() == pytest.approx(-1.25)
    env.common_step_counter = 1000
    curriculum.compute(mask)
    assert env.reward_manager.weights["rate"].item() == pytest.approx(-2.0)
    assert env.reward_manager.weights["rate2"].item() == pytest.approx(-10.0)
