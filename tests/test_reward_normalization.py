"""AGILE's reward normalisation (RewardNormalization): the scale makes i.i.d. returns about unit-variance, outliers are
clipped, the return-scale correction follows the measured returns, the stored rewards are the scaled ones, it
composes with the other PPO extensions, survives a checkpoint, and bad settings name the field (CPU, on a fake env)."""

from __future__ import annotations

import math

import pytest
import torch
from rsl_rl.algorithms import PPO
from tensordict import TensorDict

from agile.rl import PpoAlgorithmCfg, to_rsl_rl_dict
from agile.rl.algorithms.entropy_annealing import EntropyAnnealing
from agile.rl.algorithms.reward_normalization import STATE_KEY, ReturnVarianceNormalizer, RewardNormalization
from agile.rl.algorithms.sync_free_update import SyncFreeUpdate
from agile.rl.configs import RewardNormalizationCfg
from agile.rl.extensions import compose_algorithm, extended
from agile.utils.config import ConfigError
from ppo_fakes import ppo_algorithm

NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS = 64, 8, 5, 2
GAMMA = 0.99


def test_iid_rewards_are_scaled_to_unit_variance_returns():
    normalizer = ReturnVarianceNormalizer(RewardNormalizationCfg(decay=0.99, return_scale_decay=None), GAMMA)
    generator = torch.Generator().manual_seed(0)
    for _ in range(2000):
        normalizer(3.0 + 0.5 * torch.randn(4096, generator=generator))
    assert float(normalizer.mean) == pytest.approx(3.0, abs=0.02)
    assert float(normalizer.var.sqrt()) == pytest.approx(0.5, rel=0.02)
    # sigma / sqrt(1 - gamma^2) is the std of an i.i.d. discounted return: scaled, about 1
    assert float(normalizer.scale()) == pytest.approx(0.5 / math.sqrt(1 - GAMMA ** 2) + 0.01, rel=0.02)


def test_an_outlier_is_clipped_in_the_output_and_barely_moves_the_statistics():
    cfg = RewardNormalizationCfg(decay=0.9, outlier_threshold=3.0, return_scale_decay=None)
    normalizer = ReturnVarianceNormalizer(cfg, GAMMA)
    rewards = torch.zeros(1000)
    rewards[0] = -1.0e6
    scaled = normalizer(rewards)
    assert torch.isfinite(scaled).all()
    scale = float(normalizer.scale())
    assert float(scaled.min()) >= float(normalizer.mean) / scale - 3.0 - 1e-5  # clipped at the threshold
    assert float(normalizer.var) < 2.0  # the -1e6 entered the variance clipped to the running spread, not whole


def test_the_return_correction_moves_towards_unit_spread_of_the_scaled_returns():
    normalizer = ReturnVarianceNormalizer(RewardNormalizationCfg(return_scale_decay=0.0), GAMMA)
    normalizer.update_return_scale(torch.tensor([-2.0, 2.0, -2.0, 2.0]))  # std 2.31 with the correction at 1
    correction = float(normalizer.return_correction)
    assert correction == pytest.approx(torch.tensor([-2.0, 2.0, -2.0, 2.0]).std().item())
    # the same raw spread seen through the new correction: std / correction, the fixed point holds
    normalizer.update_return_scale(torch.tensor([-2.0, 2.0, -2.0, 2.0]) / correction)
    assert float(normalizer.return_correction) == pytest.approx(correction)
    untouched = ReturnVarianceNormalizer(RewardNormalizationCfg(return_scale_decay=None), GAMMA)
    untouched.update_return_scale(torch.tensor([-5.0, 5.0]))
    assert float(untouched.return_correction) == 1.0


def runner_algorithm_dict(class_name: str, reward_normalization: dict | None) -> dict:
    algorithm = {"class_name": class_name, "gamma": GAMMA, "reward_normalization": reward_normalization}
    compose_algorithm(algorithm)
    return algorithm


def make_algorithm(class_name: str = "PPO", reward_normalization: dict | None = None, **switches):
    return ppo_algorithm(class_name, NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS, gamma=GAMMA,
                         reward_normalization=reward_normalization, **switches)


def rollout(algorithm, generator: torch.Generator) -> list[torch.Tensor]:
    obs = TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM, generator=generator)}, batch_size=[NUM_ENVS])
    raw = []
    for _ in range(NUM_STEPS):
        algorithm.act(obs)
        rewards = 50.0 + 20.0 * torch.randn(NUM_ENVS, generator=generator)
        raw.append(rewards)
        algorithm.process_env_step(obs, rewards.clone(), torch.zeros(NUM_ENVS, dtype=torch.long), {})
    algorithm.compute_returns(obs)
    return raw


@pytest.mark.parametrize("switches, mixins", [({}, (RewardNormalization,)),
                                              ({"entropy_annealing": {}}, (EntropyAnnealing, RewardNormalization)),
                                              ({"sync_free_update": True}, (RewardNormalization, SyncFreeUpdate))])
def test_alone_or_with_another_extension_it_stores_scaled_rewards(switches, mixins):
    algorithm = make_algorithm("PPO", {"decay": 0.5, "return_scale_decay": None}, **switches)
    assert type(algorithm).__mro__[1:len(mixins) + 1] == mixins and isinstance(algorithm, PPO)
    assert type(algorithm).__name__ == "".join(m.__name__ for m in mixins) + "PPO"
    raw = rollout(algorithm, torch.Generator().manual_seed(1))
    stored = algorithm.storage.rewards.squeeze(-1)
    # every stored step is its raw rewards divided by one scale (that step's), well under the raw 50 +- 20
    ratios = stored / torch.stack(raw)
    assert torch.allclose(ratios, ratios[:, :1].expand_as(ratios), rtol=1e-5)
    assert float(stored.abs().max()) < 10.0
    assert extended(PPO, mixins) is type(algorithm)  # one class per combination
    algorithm.update()


def test_without_the_setting_rsl_rl_gets_its_own_class_and_no_extra_argument():
    assert runner_algorithm_dict("PPO", None) == {"class_name": "PPO", "gamma": GAMMA}
    algorithm = make_algorithm("PPO", None)
    assert type(algorithm) is PPO


def test_the_statistics_survive_a_checkpoint_and_an_old_checkpoint_starts_them_afresh():
    trained = make_algorithm("PPO", {"decay": 0.5})
    rollout(trained, torch.Generator().manual_seed(2))
    saved = trained.save()
    saved["iter"] = 7
    assert set(saved[STATE_KEY]) == {"mean", "var", "return_correction"}
    resumed = make_algorithm("PPO", {"decay": 0.5})
    assert resumed.load(saved, None, True)
    for key, value in trained.reward_normalizer.state_dict().items():
        assert torch.equal(resumed.reward_normalizer.state_dict()[key], value), key
    old = {key: value for key, value in saved.items() if key != STATE_KEY}
    fresh = make_algorithm("PPO", {"decay": 0.5})
    fresh.load(old, None, True)
    assert float(fresh.reward_normalizer.var) == 1.0


def test_a_registered_config_passes_the_setting_through_to_rsl_rl():
    import agile.tasks  # noqa: F401
    from agile.tasks import load_cfgs

    _, agent_cfg = load_cfgs("HeightTracking-G1-v0")
    agent_cfg.algorithm.reward_normalization = RewardNormalizationCfg(decay=0.99)
    algorithm = to_rsl_rl_dict(agent_cfg)["algorithm"]
    assert isinstance(algorithm["class_name"], type) and issubclass(algorithm["class_name"], RewardNormalization)
    assert algorithm["reward_normalization"]["decay"] == 0.99


@pytest.mark.parametrize("values, field", [({"decay": 1.0}, "decay"), ({"epsilon": 0.0}, "epsilon"),
                                           ({"return_scale_decay": -0.1}, "return_scale_decay"),
                                           ({"outlier_threshold": 0.0}, "outlier_threshold"),
                                           ({"decya": 0.9}, "decya")])
def test_a_bad_setting_is_named(values, field):
    with pytest.raises(ConfigError, match=field):
        runner_algorithm_dict("PPO", values)


def test_the_algorithm_config_has_no_normalisation_unless_asked():
    assert PpoAlgorithmCfg().reward_normalization is None


def test_a_resume_without_statistics_into_a_normalising_run_warms_the_critic_up():
    from types import SimpleNamespace

    from agile.rl.algorithms.reward_normalization import starts_normalizing

    normalizing_cfg = SimpleNamespace(algorithm=PpoAlgorithmCfg(reward_normalization=RewardNormalizationCfg()))
    plain_cfg = SimpleNamespace(algorithm=PpoAlgorithmCfg())
    assert starts_normalizing(normalizing_cfg, {"iter": 3})  # trained without: the returns change scale
    assert not starts_normalizing(normalizing_cfg, {"iter": 3, STATE_KEY: {}})  # trained with it
    assert not starts_normalizing(normalizing_cfg, None)  # not a resume
    assert not starts_normalizing(plain_cfg, {"iter": 3})
