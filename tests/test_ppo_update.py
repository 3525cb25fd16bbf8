"""SyncFreePPO's update (the learning rate adapted on the device, fused Adam, losses read once) does rsl-rl's PPO math:
from the same weights and the same rollout, the losses, the adapted learning rate and the weights after an update
match the plain update (CPU)."""

from __future__ import annotations

import copy

import pytest
import torch
from rsl_rl.algorithms import PPO
from tensordict import TensorDict

from agile.rl_env.rsl_rl.sync_free_ppo import SyncFreePPO

NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS = 16, 12, 10, 4


class FakeEnv:
    """What rsl-rl's algorithm construction reads of an env."""

    num_envs = NUM_ENVS
    num_actions = NUM_ACTIONS


def make_algorithm(cls, desired_kl: float):
    obs = TensorDict({"policy": torch.zeros(NUM_ENVS, OBS_DIM)}, batch_size=[NUM_ENVS])
    cfg = {"obs_groups": {"actor": ["policy"], "critic": ["policy"]}, "num_steps_per_env": NUM_STEPS,
           "multi_gpu": None,
           "actor": {"class_name": "MLPModel", "hidden_dims": [32, 32], "activation": "elu", "obs_normalization": True,
                     "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
           "critic": {"class_name": "MLPModel", "hidden_dims": [32, 32], "activation": "elu",
                      "obs_normalization": True},
           "algorithm": {"class_name": cls, "learning_rate": 1.0e-3, "schedule": "adaptive",
                         "desired_kl": desired_kl, "num_learning_epochs": 3, "num_mini_batches": 2,
                         "entropy_coef": 0.005}}
    torch.manual_seed(0)
    return PPO.construct_algorithm(obs, FakeEnv(), cfg, "cpu")


def fill_rollout(algorithm) -> None:
    generator = torch.Generator().manual_seed(1)
    obs = TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM, generator=generator)}, batch_size=[NUM_ENVS])
    torch.manual_seed(2)
    for _ in range(NUM_STEPS):
        algorithm.act(obs)
        obs = TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM, generator=generator)}, batch_size=[NUM_ENVS])
        rewards = torch.randn(NUM_ENVS, generator=generator)
        dones = torch.rand(NUM_ENVS, generator=generator) < 0.1
        algorithm.process_env_step(obs, rewards, dones, {"time_outs": torch.zeros(NUM_ENVS, dtype=torch.bool)})
    algorithm.compute_returns(obs)


@pytest.mark.parametrize("desired_kl", [0.01, 1.0e-6, 10.0])  # the learning rate held, lowered, raised
def test_the_sync_free_update_matches_rsl_rls_update(desired_kl):
    plain, sync_free = make_algorithm("PPO", desired_kl), make_algorithm(SyncFreePPO, desired_kl)
    sync_free.actor.load_state_dict(plain.actor.state_dict())
    sync_free.critic.load_state_dict(plain.critic.state_dict())
    results = []
    for algorithm in (plain, sync_free):
        fill_rollout(algorithm)
        torch.manual_seed(3)  # the mini-batch permutation
        losses = algorithm.update()
        results.append((losses, algorithm.learning_rate, copy.deepcopy(algorithm.actor.state_dict())))
    (plain_losses, plain_lr, plain_actor), (losses, lr, actor) = results
    assert lr == pytest.approx(plain_lr, rel=1e-6)
    if desired_kl == 1.0e-6:
        assert lr < 1.0e-3  # the rule acted: lowered at every mini-batch
    if desired_kl == 10.0:
        assert lr > 1.0e-3
    for name in ("value", "surrogate", "entropy"):
        assert losses[name] == pytest.approx(plain_losses[name], rel=1e-4, abs=1e-6), name
    for name, value in plain_actor.items():
        assert torch.allclose(actor[name], value, rtol=1e-4, atol=1e-6), name


def test_a_checkpoint_of_the_sync_free_update_resumes_in_either():
    sync_free = make_algorithm(SyncFreePPO, 1.0e-6)
    fill_rollout(sync_free)
    sync_free.update()
    saved = sync_free.save()
    assert isinstance(saved["optimizer_state_dict"]["param_groups"][0]["lr"], float)
    plain, again = make_algorithm("PPO", 0.01), make_algorithm(SyncFreePPO, 0.01)
    for algorithm in (plain, again):
        algorithm.load(saved, None, strict=True)
        assert algorithm.learning_rate == pytest.approx(sync_free.learning_rate)
    assert float(again.learning_rate_t) == pytest.approx(sync_free.learning_rate)
    assert again.optimizer.param_groups[0]["lr"] is again.learning_rate_t  # the update still adapts it on the device
