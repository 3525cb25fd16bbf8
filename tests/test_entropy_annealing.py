"""AGILE's entropy-coefficient annealing (`entropy_annealing`, the EntropyAnnealing mixin): the coefficient decays per
iteration once the run is past its start iteration and the ended episodes last long enough, never below its minimum;
it survives a checkpoint; bad settings name the field (CPU, rsl-rl's algorithm on a fake env)."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict

import agile.tasks
from agile.rl import to_rsl_rl_dict
from agile.rl.algorithms.entropy_annealing import EntropyAnnealing
from agile.rl.extensions import compose_algorithm
from agile.utils.config import ConfigError

NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS, EPISODE_STEPS = 8, 10, 6, 3, 20


class FakeEnv:
    """What rsl-rl's algorithm construction (and the annealing) reads of an env."""

    num_envs = NUM_ENVS
    num_actions = NUM_ACTIONS
    max_episode_length = EPISODE_STEPS


def make_algorithm(**annealing) -> EntropyAnnealing:
    obs = TensorDict({"policy": torch.zeros(NUM_ENVS, OBS_DIM)}, batch_size=[NUM_ENVS])
    cfg = {"obs_groups": {"actor": ["policy"], "critic": ["policy"]}, "num_steps_per_env": NUM_STEPS,
           "multi_gpu": None,
           "actor": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu",
                     "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
           "critic": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu"},
           "algorithm": {"class_name": "PPO",
                         "entropy_coef": 0.005, "entropy_annealing": annealing}}
    compose_algorithm(cfg["algorithm"])
    torch.manual_seed(0)
    return cfg["algorithm"]["class_name"].construct_algorithm(obs, FakeEnv(), cfg, "cpu")


def iterate(algorithm, episode_steps: int) -> dict:
    """One iteration in which every env's episodes last `episode_steps` steps (the first ends at that step)."""
    obs = TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM)}, batch_size=[NUM_ENVS])
    for step in range(1, NUM_STEPS + 1):
        algorithm.act(obs)
        dones = torch.full((NUM_ENVS,), step % episode_steps == 0)
        algorithm.process_env_step(obs, torch.randn(NUM_ENVS), dones, {"time_outs": dones})
    algorithm.compute_returns(obs)
    return algorithm.update()


def test_the_coefficient_decays_each_iteration_down_to_its_minimum():
    algorithm = make_algorithm(decay_per_iteration=0.5, min_entropy_coef=0.001)
    coefs = [iterate(algorithm, episode_steps=5)["entropy_coef"] for _ in range(4)]
    assert coefs == pytest.approx([0.0025, 0.00125, 0.001, 0.001])
    assert algorithm.entropy_coef == pytest.approx(0.001)


def test_the_start_iteration_and_the_episode_length_gate_it():
    late = make_algorithm(start_iteration=2, decay_per_iteration=0.5)
    assert [iterate(late, episode_steps=5)["entropy_coef"] for _ in range(3)] == pytest.approx([0.005, 0.005, 0.0025])
    # the episodes end after 5 of 20 steps: 25% of the length, short of the 30% asked
    short = make_algorithm(min_episode_length_share=0.3, decay_per_iteration=0.5)
    losses = iterate(short, episode_steps=5)
    assert losses["mean_episode_length_steps"] == pytest.approx(5.0) and losses["entropy_coef"] == 0.005
    # 10 steps (50%): it decays
    assert iterate(short, episode_steps=10)["entropy_coef"] == pytest.approx(0.0025)
    # no episode ended in the iteration: nothing known of their length, no decay
    assert "mean_episode_length_steps" not in iterate(short, episode_steps=NUM_STEPS + 1)
    assert short.entropy_coef == pytest.approx(0.0025)


def test_a_checkpoint_keeps_the_coefficient_and_the_iteration():
    algorithm = make_algorithm(start_iteration=1, decay_per_iteration=0.5)
    for _ in range(3):
        iterate(algorithm, episode_steps=5)
    saved = algorithm.save()
    saved["iter"] = 2  # what the runner adds: the last iteration run
    resumed = make_algorithm(start_iteration=1, decay_per_iteration=0.5)
    assert resumed.load(saved, None, strict=True)
    assert (resumed.iteration, resumed.entropy_coef) == (3, pytest.approx(0.00125))
    # an older checkpoint (no coefficient in it) resumes at the configured one; fine-tuning from an actor alone
    # (the iteration not loaded) starts the count anew
    del saved["entropy_coef"]
    older = make_algorithm(start_iteration=1, decay_per_iteration=0.5)
    older.load(saved, None, strict=True)
    assert (older.iteration, older.entropy_coef) == (3, 0.005)
    actor_only = make_algorithm(start_iteration=1, decay_per_iteration=0.5)
    actor_only.load(saved, {"actor": True}, strict=True)
    assert actor_only.iteration == 0


@pytest.mark.parametrize(("field", "value", "message"), [
    ("decay_per_iteration", 1.5, "decay_per_iteration: 1.5"),
    ("min_episode_length_share", -0.1, "min_episode_length_share: -0.1"),
    ("start_iteration", -1, "start_iteration: -1"),
    ("warmup", 3, "unknown ['warmup']; its fields: ['start_iteration'"),
])
def test_bad_settings_name_the_field(field, value, message):
    with pytest.raises(ConfigError, match=message.replace("[", r"\[").replace("]", r"\]")):
        make_algorithm(**{field: value})


def test_pick_place_anneals_as_agile_does():
    _, agent_cfg = agile.tasks.load_cfgs("PickPlace-G1-v0")
    algorithm = to_rsl_rl_dict(agent_cfg)["algorithm"]
    cls = algorithm["class_name"]
    assert issubclass(cls, EntropyAnnealing) and cls.__name__ == "EntropyAnnealingPPO"
    assert algorithm["entropy_annealing"] == {"start_iteration": 2000, "min_episode_length_share": 0.3,
                                              "decay_per_iteration": 0.9998, "min_entropy_coef": 0.001}
    agent_cfg.algorithm.entropy_annealing.decay_per_iteration = 0.0
    with pytest.raises(ConfigError, match="decay_per_iteration: 0.0"):
        to_rsl_rl_dict(agent_cfg)
