"""Faults a user meets, injected: non-finite actions and reward terms, resumes, broken checkpoints and caches,
configs outside their domain. Each test fails without the rule it checks."""

import dataclasses

import gymnasium as gym
import pytest
import torch

from commands import FLAT_GROUND

import agile.tasks  # noqa: F401
from agile.rl_env.mdp import last_action
from agile.rl import RslRlVecEnvWrapper, flatten_groups
from agile.sim.terrain import TerrainGeneratorCfg, cache_dir, cache_key, load_or_generate_terrain
from agile.utils.config import ConfigError


@pytest.fixture(scope="module")
def env():
    env = gym.make("Velocity-T1-v0", num_envs=2, device="cpu", seed=0, overrides=FLAT_GROUND).unwrapped
    yield env
    env.close()


def all_finite(obs) -> bool:
    return all(torch.isfinite(v).all() for v in flatten_groups(obs).values())


def test_a_nan_action_is_replaced_ended_and_counted(env):
    env.reset()
    action = torch.zeros(2, env.action_manager.total_action_dim)
    action[0, 3] = float("nan")
    action[1, 5] = 0.1  # a finite action
    obs, reward, terminated, truncated, extras = env.step(action)
    assert terminated.tolist() == [True, False] and not truncated[0]
    assert torch.isfinite(reward).all() and all_finite(obs)
    assert float(extras["log"]["Episode_Termination/invalid_action"]) == 1.0  # the one env that ended
    assert (env.episode_length_buf[0] == 0) and (env.episode_length_buf[1] == 1)  # env 0 was reset
    for _ in range(2):  # nothing of it lingers in the action history, the rewards or the observations
        obs, reward, terminated, _, _ = env.step(torch.zeros_like(action))
        assert torch.isfinite(reward).all() and all_finite(obs) and not terminated.any()


def test_the_last_action_is_the_raw_action_and_far_off_ones_are_clamped_to_clip_actions():
    env = gym.make("Velocity-T1-v0", num_envs=4, device="cpu", seed=0, overrides=FLAT_GROUND).unwrapped
    wrapped = RslRlVecEnvWrapper(env)
    term = env.action_manager.get_term("joint_pos")
    clip = env.action_manager.clip_actions
    assert clip == env.cfg.clip_actions == 100.0
    # T1: target = action + default joint position, cut at ±1 rad. An action beyond that is seen raw by the
    # last-action observation (Isaac Lab, AGILE; the shipped T1 policy learned so), while its target stays cut
    beyond = (1.0 - term.offset) + 0.3
    env.step(beyond)
    torch.testing.assert_close(env.action_manager.action, beyond)
    torch.testing.assert_close(last_action(env), beyond)
    torch.testing.assert_close(term.processed_actions, torch.ones_like(beyond))
    far = torch.full((4, env.action_manager.total_action_dim), 1e6)
    for sign in (1.0, -1.0, 1.0, -1.0):  # unclamped, the action rate of ±1e6 cost about -6.7e11 per step
        _, reward, _, _ = wrapped.step(sign * far)
        assert reward.abs().max() < 1e5, reward
    running = env.episode_length_buf > 0  # an env that fell was reset, its action history zeroed
    assert running.any()
    torch.testing.assert_close(env.action_manager.action[running], -clip * torch.ones_like(far[running]))
    faulty = far.clone()
    faulty[0, 0], faulty[1, 0] = float("nan"), float("inf")  # not turned into numbers before the env counts them
    wrapped.step(faulty)
    assert env.action_manager.invalid_action.tolist() == [True, True, False, False]


def test_clip_actions_must_be_positive():
    with pytest.raises(ConfigError, match="clip_actions must be positive"):
        gym.make("Velocity-T1-v0", num_envs=1, device="cpu", overrides=[*FLAT_GROUND, "clip_actions=0.0"])


def test_a_non_finite_reward_term_counts_zero_and_is_counted_per_term():
    def nan_in_env_0(env, **params):
        value = torch.zeros(env.num_envs)
        value[0] = float("nan")
        return value

    env = gym.make("Velocity-T1-v0", num_envs=2, device="cpu", overrides=FLAT_GROUND).unwrapped
    env.reward_manager.funcs["lin_vel_z"] = nan_in_env_0
    for _ in range(3):
        _, reward, _, _, _ = env.step(torch.zeros(2, env.action_manager.total_action_dim))
        assert torch.isfinite(reward).all()
    assert int(env.reward_manager.nonfinite_count["lin_vel_z"]) == 3
    assert int(env.reward_manager.nonfinite_count["feet_slip"]) == 0
    assert torch.isfinite(env.reward_manager.episode_sums["lin_vel_z"]).all()


def test_training_state_round_trip_restores_the_step_counter_terrain_levels_and_episode_counts():
    """The terrain rows, and the successes and failures each env has gathered towards its next move: without the
    counts no env could move up for its first 4 episodes after a resume (a flat terrain curve for ~200 iterations)."""
    overrides = ["scene.terrain.num_rows=4", "scene.terrain.num_cols=2", "scene.terrain.size_m=4.0",
                 "scene.terrain.border_width_m=1.0"]
    first = gym.make("Velocity-T1-v0", num_envs=2, device="cpu", overrides=overrides).unwrapped
    first.common_step_counter.fill_(123_456)
    first.sim.update_terrain_levels(torch.tensor([True, True]), torch.tensor([False, False]))
    outcomes = first.curriculum_manager.funcs["terrain_levels"].outcomes
    outcomes.num_successes.copy_(torch.tensor([3, 1]))
    outcomes.num_failures.copy_(torch.tensor([0, 7]))
    state = first.training_state()
    assert state["curriculum/terrain_levels.outcomes.num_successes"].tolist() == [3, 1]
    second = gym.make("Velocity-T1-v0", num_envs=2, device="cpu", seed=7, overrides=overrides).unwrapped
    second.load_training_state(state)
    assert int(second.common_step_counter) == 123_456
    assert second.sim.terrain_levels.tolist() == first.sim.terrain_levels.tolist()
    torch.testing.assert_close(second.env_origins, first.env_origins)
    restored = second.curriculum_manager.funcs["terrain_levels"].outcomes
    assert restored.num_successes.tolist() == [3, 1] and restored.num_failures.tolist() == [0, 7]


def test_a_training_state_of_another_env_count_is_spread_by_terrain_column(capsys):
    """A training moved to more or fewer envs (another GPU, more GPUs) keeps its climb: each env takes the terrain
    level and the curriculum counts of one of the checkpoint's envs on its own column (env i is on column i % 2
    here); a checkpoint with fewer envs than columns is refused."""
    overrides = ["scene.terrain.num_rows=4", "scene.terrain.num_cols=2", "scene.terrain.size_m=4.0",
                 "scene.terrain.border_width_m=1.0"]
    first = gym.make("Velocity-T1-v0", num_envs=4, device="cpu", overrides=overrides).unwrapped
    first.sim.set_terrain_levels(torch.tensor([0, 1, 2, 3]))
    outcomes = first.curriculum_manager.funcs["terrain_levels"].outcomes
    outcomes.num_successes.copy_(torch.tensor([1, 2, 3, 0]))
    state = first.training_state()
    more = gym.make("Velocity-T1-v0", num_envs=6, device="cpu", overrides=overrides).unwrapped
    more.load_training_state(state)
    # column 0: the checkpoint's envs 0 and 2, in turn; column 1: its envs 1 and 3
    assert more.sim.terrain_levels.tolist() == [0, 1, 2, 3, 0, 1]
    assert more.curriculum_manager.funcs["terrain_levels"].outcomes.num_successes.tolist() == [1, 2, 3, 0, 1, 2]
    assert more.sim.terrain_types.tolist() == [0, 1, 0, 1, 0, 1]
    assert "the checkpoint's training state is of 4 envs, this env has 6" in capsys.readouterr().out
    fewer = gym.make("Velocity-T1-v0", num_envs=2, device="cpu", overrides=overrides).unwrapped
    fewer.load_training_state(state)
    assert fewer.sim.terrain_levels.tolist() == [0, 1]
    one = gym.make("Velocity-T1-v0", num_envs=1, device="cpu", overrides=overrides).unwrapped
    with pytest.raises(ValueError, match="1 envs do not cover the terrain's 2 columns"):
        more.load_training_state(one.training_state())


def test_training_state_round_trip_restores_adaptive_curricula(capsys):
    """An adaptive curriculum's state (here the pushing curriculum's push scale; the stand-up lift's strength the
    same way) comes back on resume, in place: the push event reads the very tensor the curriculum writes."""
    first = gym.make("Velocity-G1-Teacher-v0", num_envs=2, device="cpu", overrides=FLAT_GROUND).unwrapped
    pushing = first.curriculum_manager.funcs["pushing_velocity"]
    pushing.scale.copy_(torch.tensor([0.5, 0.25, 1.0, 1.0, 1.0, 2.0]))
    state = first.training_state()
    assert "curriculum/pushing_velocity.scale" in state
    second = gym.make("Velocity-G1-Teacher-v0", num_envs=2, device="cpu", seed=3, overrides=FLAT_GROUND).unwrapped
    second.load_training_state(state)
    restored = second.curriculum_manager.funcs["pushing_velocity"].scale
    assert restored.tolist() == [0.5, 0.25, 1.0, 1.0, 1.0, 2.0]
    assert second.event_manager.term_cfgs["push_robot"].params["velocity_scale"] is restored
    # a checkpoint from before the curriculum had state: it starts afresh, and says so
    older = {k: v for k, v in state.items() if not k.startswith("curriculum/")}
    third = gym.make("Velocity-G1-Teacher-v0", num_envs=2, device="cpu", overrides=FLAT_GROUND).unwrapped
    third.load_training_state(older)
    assert third.curriculum_manager.funcs["pushing_velocity"].scale.tolist() == [1.0] * 6
    assert "pushing_velocity.scale" in capsys.readouterr().out
    with pytest.raises(ValueError, match="lift.scale"):
        third.load_training_state({**state, "curriculum/lift.scale": torch.ones(())})


def test_resume_skips_a_truncated_newest_checkpoint(tmp_path, capsys):
    from agile.run import task_setup

    run = tmp_path / "exp" / "2026-01-01_00-00-00"
    run.mkdir(parents=True)
    torch.save({"iter": 6, "actor_state_dict": {}}, run / "model_6.pt")
    (run / "model_7.pt").write_bytes((run / "model_6.pt").read_bytes()[:40])  # a write cut short
    assert task_setup.latest_checkpoint(str(tmp_path), "exp") == str(run / "model_6.pt")
    assert "skipping" in capsys.readouterr().out


@pytest.mark.parametrize("command", [["eval", "--checkpoint"], ["play", "--checkpoint"], ["export", "--checkpoint"],
                                     ["train", "--resume", "--checkpoint"], ["train", "--init_policy"]],
                         ids=["eval", "play", "export", "train-resume", "train-init_policy"])
def test_a_checkpoint_cut_short_is_refused_in_one_line_with_exit_2(command, tmp_path, capsys):
    import importlib

    from agile.tasks import pretrained_policy

    cut = tmp_path / "model_cut.pt"
    cut.write_bytes(pretrained_policy("Velocity-T1-v0").read_bytes()[:1000])  # a copy broken off
    main = importlib.import_module(f"agile.run.{command[0]}").main
    with pytest.raises(SystemExit) as exit_info:
        main(["--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "1", *command[1:], str(cut),
              *(["--out", str(tmp_path / "out")] if command[0] == "export" else [])])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2
    assert err.count("\n") == 1 and "cannot be read" in err and str(cut) in err and "Traceback" not in err, err


def test_a_missing_checkpoint_is_refused_before_anything_is_built(capsys):
    from agile.run import arguments
    from agile.run.train import main

    with pytest.raises(SystemExit) as exit_info:
        main(["--task", "Velocity-T1-v0", "--checkpoint", "no/such/model_1.pt"])
    assert exit_info.value.code == 2 and "--checkpoint file not found: no/such/model_1.pt" in capsys.readouterr().err
    from agile.rl.checkpoints import TRUST_FLAG

    assert arguments.TRUST_FLAG == TRUST_FLAG


def test_a_corrupted_terrain_cache_is_rebuilt_and_a_bad_terrain_is_never_written(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("AGILE_CACHE_DIR", str(tmp_path))
    cfg = TerrainGeneratorCfg(size_m=2.0, num_rows=2, num_cols=2, border_width_m=0.5)
    first = load_or_generate_terrain(cfg)
    path = cache_dir() / f"terrain_{cache_key(cfg)}.npz"
    for damage in (lambda b: b[: len(b) // 2], lambda b: b[:100] + bytes([b[100] ^ 0xFF]) + b[101:]):
        good = path.read_bytes()
        path.write_bytes(damage(good))
        again = load_or_generate_terrain(cfg)
        assert (again.heights_m == first.heights_m).all()
        assert "generating it again" in capsys.readouterr().out
    bad = dataclasses.replace(cfg, num_rows=0)
    with pytest.raises(ConfigError, match="scene.terrain.num_rows must be at least 1, got 0"):
        load_or_generate_terrain(bad)
    assert not (cache_dir() / f"terrain_{cache_key(bad)}.npz").exists()


@pytest.mark.parametrize("override, message", [
    ("decimation=0", "decimation must be a whole number >= 1"),
    ("decimation=-1", "decimation must be a whole number >= 1"),  # ran with every step a time-out
    ("sim.physics_dt_s=0.0", "sim.physics_dt_s must be positive"),
    ("episode_length_s=-5.0", "episode_length_s must be positive"),
    ("observations.policy.history_length=-1", "observations.policy.history_length must be >= 0"),
    ("scene.max_init_terrain_level=-1", "scene.max_init_terrain_level must be >= 0"),
    ("commands.base_velocity.ranges.lin_vel_x=(0.5, -0.5)", "'base_velocity'.*ranges.lin_vel_x must be ordered"),
    ("commands.base_velocity.resampling_time_range_s=(-1.0, 2.0)", "resampling_time_range_s must lie within"),
    ("commands.base_velocity.rel_standing_envs=1.5", "rel_standing_envs is a share"),
    ("rewards.track_lin_vel_xy_exp.params.std=0.0", "'track_lin_vel_xy_exp', param 'std'.*must be positive"),
    ("events.push_robot.interval_range_s=(5.0, 2.0)", "'push_robot'.*interval_range_s must be ordered"),
    # before: "joint regex '.*' matches no joint", a regex the user never wrote
    ("actions.joint_pos.joint_names=[]", "action term 'joint_pos': no joint of 'robot' regex given"),
    ("events.push_robot.params.velocity_range={'x': (0.5, -0.5)}",
     "'push_robot', param 'velocity_range\\['x'\\]'.*ordered"),
    ("sim.solver.njmax=0", "sim.solver.njmax must be positive"),  # MuJoCo printed an overflow every step
])
def test_a_value_outside_its_domain_is_named_at_build(override, message):
    # flat ground unless the value is the terrain's: a rough terrain takes seconds to build on a CPU
    flat = [] if "terrain" in override else FLAT_GROUND
    with pytest.raises(ConfigError, match=message):
        gym.make("Velocity-T1-v0", num_envs=1, device="cpu", overrides=[override, *flat])
