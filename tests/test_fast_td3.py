"""FastTD3 (agile.rl.fast_td3, agile.rl.replay_buffer): n-step returns cut at episode ends against a reference by
hand, the C51 projection, the algorithm learning a one-step problem, and the command: T1 trained 2 iterations on the
CPU, its checkpoint evaluated as a PPO checkpoint is, bad input refused."""

import json

import pytest
import torch
from tensordict import TensorDict

import agile.tasks  # noqa: F401
from agile.errors import AgileError
from agile.rl import DistributionCfg, MlpModelCfg, PpoRunnerCfg
from agile.rl.fast_td3 import FastTd3, FastTd3Cfg, actor_mean, build_actor, project_distribution
from agile.rl.replay_buffer import ReplayBuffer


def reference_return(rewards, terminated, truncated, t, n, gamma):
    """(return, bootstrap step or None, discount, valid) of step t by the rules of agile.rl.replay_buffer."""
    total = 0.0
    for k in range(n):
        if truncated[t + k] and not terminated[t + k]:
            return (total, t + k, gamma ** k, True) if k > 0 else (total, t, 0.0, False)
        total += gamma ** k * rewards[t + k]
        if terminated[t + k]:
            return total, None, 0.0, True
    return total, t + n, gamma ** n, True


def test_n_step_returns_stop_at_terminations_and_bootstrap_before_time_outs():
    gamma, n, steps = 0.9, 3, 12
    rewards = [[float(1 + t + 10 * e) for t in range(steps)] for e in range(2)]
    terminated = [[t in (3, 9) for t in range(steps)], [t == 7 for t in range(steps)]]
    truncated = [[t == 6 for t in range(steps)], [t in (1, 2, 7) for t in range(steps)]]  # env 1, 7: both at once
    buffer = ReplayBuffer(num_envs=2, steps_per_env=8, actor_obs_dim=2, critic_obs_dim=1, action_dim=1, device="cpu")
    for t in range(steps):
        buffer.add(actor_obs=torch.tensor([[t, 0.0], [t, 1.0]]), critic_obs=torch.zeros(2, 1),
                   actions=torch.zeros(2, 1), rewards=torch.tensor([rewards[0][t], rewards[1][t]]),
                   terminated=torch.tensor([terminated[0][t], terminated[1][t]]),
                   truncated=torch.tensor([truncated[0][t], truncated[1][t]]))
    batch = buffer.sample(batch_size=4000, n_steps=n, gamma=gamma, generator=torch.Generator().manual_seed(0))
    seen = set()
    for i in range(4000):
        t, e = int(batch.actor_obs[i, 0]), int(batch.actor_obs[i, 1])
        seen.add((t, e))
        ret, boot, discount, valid = reference_return(rewards[e], terminated[e], truncated[e], t, n, gamma)
        assert bool(batch.valid[i]) == valid, (t, e)
        if not valid:
            continue
        assert float(batch.returns[i]) == pytest.approx(ret), (t, e)
        assert float(batch.bootstrap_discount[i]) == pytest.approx(discount), (t, e)
        if boot is not None:
            assert int(batch.next_actor_obs[i, 0]) == boot and int(batch.next_actor_obs[i, 1]) == e
    # the ring holds steps 4..11; those with 3 later steps stored: 4..8, in both envs
    assert seen == {(t, e) for t in range(4, 9) for e in range(2)}


def test_the_projection_keeps_the_mass_and_shifts_the_mean():
    support = torch.linspace(-10.0, 10.0, 51)
    probs = torch.softmax(torch.randn(5, 51, generator=torch.Generator().manual_seed(1)), -1)
    returns, discount = torch.tensor([0.3, -1.0, 2.0, 0.0, 0.7]), torch.tensor([0.9, 0.5, 0.0, 1.0, 0.81])
    projected = project_distribution(probs * 0.5, returns, discount, support)
    torch.testing.assert_close(projected.sum(-1), torch.full((5,), 0.5))
    # no clamping at the support's ends here (|return + discount * z| stays within 10 where mass lies)...
    inside = ((returns[:, None] + discount[:, None] * support).abs() <= 10.0) | (probs < 1e-12)
    mean = (projected * support).sum(-1) / 0.5
    expected = returns + discount * (probs * support).sum(-1)
    torch.testing.assert_close(mean[inside.all(-1)], expected[inside.all(-1)], atol=1e-4, rtol=0)
    # ...and no bootstrap puts all the mass on the return itself
    assert float((projected[2] * support).sum() / 0.5) == pytest.approx(2.0, abs=1e-5)


def test_the_actor_learns_a_one_step_problem():
    """Every step ends its episode with the reward -(a - target)^2, target = 0.5 * obs[0]: the actor must output
    the target (the critic's support holds every reward)."""
    torch.manual_seed(0)
    policy = PpoRunnerCfg(actor=MlpModelCfg(hidden_dims=[32, 32], obs_normalization=True,
                                            distribution_cfg=DistributionCfg()))
    cfg = FastTd3Cfg(policy=policy, critic_hidden_dims=[64, 64], num_atoms=51, v_min=-2.0, v_max=0.5, n_steps=1,
                     batch_size=256, action_bound=1.0, actor_learning_rate=1e-3, critic_learning_rate=1e-3,
                     weight_decay=0.0, policy_frequency=1, mixed_precision=False)
    obs = TensorDict({"policy": torch.zeros(64, 2), "critic": torch.zeros(64, 2)}, batch_size=[64])
    actor, _ = build_actor(cfg, obs, 1, "cpu")
    alg = FastTd3(cfg, actor, critic_obs_dim=2, action_dim=1, device="cpu")
    buffer = ReplayBuffer(num_envs=64, steps_per_env=64, actor_obs_dim=2, critic_obs_dim=2, action_dim=1,
                          device="cpu")
    for _ in range(64):
        x = torch.rand(64, 2) * 2 - 1
        actions = (torch.rand(64, 1) * 2 - 1)
        buffer.add(actor_obs=x, critic_obs=x, actions=actions, rewards=-(actions[:, 0] - 0.5 * x[:, 0]) ** 2,
                   terminated=torch.ones(64, dtype=torch.bool), truncated=torch.zeros(64, dtype=torch.bool))
    probe = torch.rand(256, 2) * 2 - 1
    target = 0.5 * probe[:, :1]
    with torch.no_grad():
        error_before = float((actor_mean(actor, probe) - target).abs().mean())
    for _ in range(600):
        alg.update(buffer.sample(batch_size=cfg.batch_size, n_steps=1, gamma=cfg.gamma))
    with torch.no_grad():
        error_after = float((actor_mean(actor, probe) - target).abs().mean())
    assert error_after < 0.08 < error_before, (error_before, error_after)


def test_settings_that_cannot_train_are_refused_by_name():
    from agile.utils.config import ConfigError

    for change, field in ((dict(buffer_steps_per_env=3), "buffer_steps_per_env"), (dict(v_min=20.0), "v_min"),
                          (dict(batch_size=0), "batch_size"), (dict(exploration_std_min=0.5), "exploration_std_min")):
        with pytest.raises(ConfigError, match=field):
            FastTd3Cfg(**change).check()


def test_the_trainer_is_refused_where_it_cannot_train(tmp_path):
    from agile.run.train import train

    for kwargs, message in ((dict(task="Shared-Go1-Velocity-v0"), "needs a single-agent task"),
                            (dict(task="StandUp-T1-v0"), "the tasks with one: Velocity-G1-History-v0, Velocity-T1-v0"),
                            (dict(task="Velocity-T1-v0", resume=True), "does not take --resume")):
        with pytest.raises(AgileError, match=message):
            train(trainer="fast_td3", log_root=str(tmp_path), **kwargs)


def test_t1_trains_and_its_checkpoint_evaluates_as_a_ppo_checkpoint(tmp_path):
    from agile.rl.checkpoints import load_checkpoint
    from agile.run.eval import evaluate_checkpoint
    from agile.run.train import train

    result = train(task="Velocity-T1-v0", trainer="fast_td3", num_envs=8, device="cpu", max_iterations=2,
                   log_root=str(tmp_path), overrides=["agent.num_steps_per_env=4", "agent.batch_size=64",
                                                      "agent.buffer_steps_per_env=16", "agent.learning_starts=2"])
    contents = load_checkpoint(result.checkpoint)
    assert contents["iter"] == 1 and "optimizer_state_dict" not in contents
    assert contents["infos"]["trainer"] == "fast_td3" and "env_state" in contents["infos"]
    saved = json.loads(json.dumps(contents["infos"]["fast_td3"]))
    assert saved["batch_size"] == 64 and saved["policy"]["actor"]["hidden_dims"] == [256, 256, 128]
    assert set(result.exported) == {"jit", "onnx", "io_descriptor"}
    metrics = evaluate_checkpoint(task="Velocity-T1-v0", checkpoint=result.checkpoint, num_envs=2, device="cpu",
                       episode_length_s=0.2)
    assert metrics["episodes"] >= 2
