"""AGILE's L2C2 term (agile.rl.algorithms.l2c2): zero where consecutive observations agree or an episode ends between
them, grows with the change and its weights, enters the update and its log, composes with reward normalisation, and
is refused with rsl-rl's own update, which has no place for it (CPU, on a fake env)."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict

from agile.rl.algorithms.l2c2 import L2C2
from agile.rl.algorithms.reward_normalization import RewardNormalization
from agile.rl.algorithms.sync_free_update import SyncFreeUpdate
from agile.utils.config import ConfigError
from ppo_fakes import ppo_algorithm

NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS = 16, 6, 4, 3


def make(l2c2: dict | None = None, **settings):
    return ppo_algorithm("PPO", NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS, sync_free_update=True, l2c2=l2c2, **settings)


def fill_rollout(algorithm, observations: torch.Tensor, dones: torch.Tensor) -> None:
    """Store a rollout whose observations at step t are `observations[t]` (T, N, D) and whose episodes end where
    `dones` (T, N) is 1."""
    for t in range(NUM_STEPS):
        obs = TensorDict({"policy": observations[t]}, batch_size=[NUM_ENVS])
        algorithm.act(obs)
        algorithm.process_env_step(obs, torch.randn(NUM_ENVS), dones[t].long(), {})
    algorithm.compute_returns(TensorDict({"policy": observations[-1]}, batch_size=[NUM_ENVS]))


def term(algorithm, seed: int = 3) -> float:
    batch = next(iter(algorithm.storage.mini_batch_generator(2, 1)))
    torch.manual_seed(seed)
    return float(algorithm.regularization_loss(batch).detach())


def walking_observations() -> torch.Tensor:
    generator = torch.Generator().manual_seed(0)
    return torch.cumsum(torch.randn(NUM_STEPS, NUM_ENVS, OBS_DIM, generator=generator), dim=0)


def test_still_observations_and_episode_ends_cost_nothing():
    still = make({})
    fill_rollout(still, torch.ones(NUM_STEPS, NUM_ENVS, OBS_DIM), torch.zeros(NUM_STEPS, NUM_ENVS))
    assert term(still) == 0.0
    ending = make({})  # the observations move, but every step ends an episode: no pair is within one
    fill_rollout(ending, walking_observations(), torch.ones(NUM_STEPS, NUM_ENVS))
    assert term(ending) == 0.0
    moving = make({})
    fill_rollout(moving, walking_observations(), torch.zeros(NUM_STEPS, NUM_ENVS))
    assert term(moving) > 0.0


def test_the_term_is_linear_in_its_weights():
    values = {}
    for weights in ((1.0, 0.0), (2.0, 0.0), (0.0, 1.0), (1.0, 1.0)):
        algorithm = make({"lambda_actor": weights[0], "lambda_critic": weights[1]})
        fill_rollout(algorithm, walking_observations(), torch.zeros(NUM_STEPS, NUM_ENVS))
        values[weights] = term(algorithm)
    assert values[(2.0, 0.0)] == pytest.approx(2.0 * values[(1.0, 0.0)], rel=1e-5)
    assert values[(1.0, 1.0)] == pytest.approx(values[(1.0, 0.0)] + values[(0.0, 1.0)], rel=1e-5)
    assert values[(0.0, 1.0)] > 0.0


def test_it_enters_the_update_and_its_log():
    with_term, without = make({}), make(None)
    assert isinstance(with_term, L2C2) and isinstance(without, SyncFreeUpdate) and not isinstance(without, L2C2)
    for algorithm in (with_term, without):
        fill_rollout(algorithm, walking_observations(), torch.zeros(NUM_STEPS, NUM_ENVS))
    losses = with_term.update()
    assert losses["l2c2"] > 0.0 and "l2c2" not in without.update()


def test_it_composes_with_reward_normalisation():
    algorithm = make({}, reward_normalization={})
    assert isinstance(algorithm, RewardNormalization) and isinstance(algorithm, L2C2)
    assert type(algorithm).__name__ == "RewardNormalizationL2C2SyncFreeUpdatePPO"
    fill_rollout(algorithm, walking_observations(), torch.zeros(NUM_STEPS, NUM_ENVS))
    assert algorithm.update()["l2c2"] > 0.0


def test_with_rsl_rls_own_update_it_is_refused_naming_both():
    with pytest.raises(ConfigError, match=r"algorithm\.l2c2 cannot combine with rsl-rl's own update: it needs "
                                          r"algorithm\.sync_free_update or algorithm\.captured_update"):
        ppo_algorithm("PPO", NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS, l2c2={})


@pytest.mark.parametrize("values, field", [({"lambda_actor": -1.0}, "lambda_actor"),
                                           ({"lambda_critic": float("nan")}, "lambda_critic"),
                                           ({"lamda_actor": 1.0}, "lamda_actor")])
def test_a_bad_setting_is_named(values, field):
    with pytest.raises(ConfigError, match=field):
        make(values)


@pytest.mark.gpu
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA device")
def test_the_captured_update_replays_the_term_with_new_draws():
    """The captured update records the mini-batch step, the L2C2 term's random pairs included, and replays it: the
    replayed updates log a term that changes with the draws and the rollout."""
    algorithm = ppo_algorithm("PPO", NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS, device="cuda:0", captured_update=True,
                              l2c2={})
    terms = []
    for _ in range(4):  # the first update is eager, the second captures, the rest replay
        # the rollout as rsl-rl's runner collects it, under inference mode: an actor forward with autograd on the
        # default stream would tie the parameters' gradient accumulation to that stream, which capture refuses
        with torch.inference_mode():
            for t in range(NUM_STEPS):
                obs = TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM, device="cuda:0") * (t + 1)},
                                 batch_size=[NUM_ENVS], device="cuda:0")
                algorithm.act(obs)
                algorithm.process_env_step(obs, torch.randn(NUM_ENVS, device="cuda:0"),
                                           torch.zeros(NUM_ENVS, dtype=torch.long, device="cuda:0"), {})
            algorithm.compute_returns(obs)
        terms.append(algorithm.update()["l2c2"])
    assert algorithm.graph is not None and all(term > 0.0 for term in terms)
    assert len(set(terms[2:])) == 2  # replays draw anew
