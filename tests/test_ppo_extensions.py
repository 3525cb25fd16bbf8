"""The one way to extend rsl-rl's algorithms (agile.rl.extensions): each extension switched on and off from the
algorithm config, several combined into one class that trains, what cannot combine refused by name, the retired class names
(checkpoints, recipes, docs) still loading, and the rsl-rl version the adapter checks (CPU, on a fake env)."""

from __future__ import annotations

import pytest
import torch
from rsl_rl.algorithms import PPO, Distillation
from tensordict import TensorDict

import agile.tasks
from agile.rl import to_rsl_rl_dict
from agile.rl.algorithms.captured_update import CapturedUpdate
from agile.rl.algorithms.distillation import MirrorLoss
from agile.rl.algorithms.entropy_annealing import EntropyAnnealing
from agile.rl.algorithms.l2c2 import L2C2
from agile.rl.algorithms.reward_normalization import RewardNormalization
from agile.rl.algorithms.sync_free_update import SyncFreeUpdate
from agile.rl.extensions import EXTENSIONS, compose_algorithm
from agile.rl.rsl_rl_adapter import RSL_RL_VERSION, RslRlVersionError, check_rsl_rl_version
from agile.utils.config import ConfigError, apply_overrides
from ppo_fakes import ppo_algorithm

NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS = 8, 6, 4, 2

SWITCHED_ON = {"entropy_annealing": ({}, EntropyAnnealing), "reward_normalization": ({}, RewardNormalization),
               "sync_free_update": (True, SyncFreeUpdate), "captured_update": (True, CapturedUpdate)}
"""PPO extension -> (the value that switches it on, its mixin); L2C2 needs an update of its own (below)."""


def composed(**algorithm) -> type:
    algorithm.setdefault("class_name", "PPO")
    compose_algorithm(algorithm)
    return algorithm["class_name"] if isinstance(algorithm["class_name"], type) else None


def test_every_extension_has_a_test_here():
    assert {e.key for e in EXTENSIONS} == {*SWITCHED_ON, "l2c2", "mirror_loss_coeff"}


@pytest.mark.parametrize("key", sorted(SWITCHED_ON))
def test_each_extension_is_switched_on_and_off_by_its_field(key):
    value, mixin = SWITCHED_ON[key]
    on = composed(**{key: value})
    assert issubclass(on, mixin) and issubclass(on, PPO)
    off = {"class_name": "PPO", key: False if value is True else None}
    compose_algorithm(off)
    assert off == {"class_name": "PPO"}  # rsl-rl's own class, and no argument it does not take


def test_l2c2_on_and_off_over_the_sync_free_update():
    assert issubclass(composed(sync_free_update=True, l2c2={}), L2C2)
    off = composed(sync_free_update=True, l2c2=None)
    assert issubclass(off, SyncFreeUpdate) and not issubclass(off, L2C2)


def test_the_distillation_mirror_loss_on_and_off_by_its_weight():
    on = {"class_name": "Distillation", "mirror_loss_coeff": 0.5, "mirror_func": "agile.rl_env.mdp.symmetry:lr_mirror"}
    compose_algorithm(on)
    assert issubclass(on["class_name"], MirrorLoss) and issubclass(on["class_name"], Distillation)
    assert on["mirror_loss_coeff"] == 0.5 and "mirror_func" in on  # the mixin takes both
    off = {"class_name": "Distillation", "mirror_loss_coeff": 0.0, "mirror_func": None}
    compose_algorithm(off)
    assert off == {"class_name": "Distillation"}


def test_combined_extensions_are_one_class_that_trains_and_logs_each():
    """Annealing, reward normalisation and L2C2 over the captured update (eager on a CPU): one class, outermost first,
    whose update runs and logs what each adds."""
    algorithm = ppo_algorithm("PPO", NUM_ENVS, NUM_STEPS, OBS_DIM, NUM_ACTIONS, captured_update=True, l2c2={},
                              reward_normalization={}, entropy_coef=0.004,
                              entropy_annealing={"decay_per_iteration": 0.5})
    assert type(algorithm).__mro__[1:6] == (EntropyAnnealing, RewardNormalization, L2C2, CapturedUpdate,
                                            SyncFreeUpdate)
    assert type(algorithm).__name__ == "EntropyAnnealingRewardNormalizationL2C2CapturedUpdatePPO"
    generator = torch.Generator().manual_seed(0)
    for t in range(NUM_STEPS):
        obs = TensorDict({"policy": torch.randn(NUM_ENVS, OBS_DIM, generator=generator)}, batch_size=[NUM_ENVS])
        algorithm.act(obs)
        algorithm.process_env_step(obs, torch.randn(NUM_ENVS, generator=generator),
                                   (torch.arange(NUM_ENVS) == t).long(), {})  # one episode ends a step
    algorithm.compute_returns(obs)
    losses = algorithm.update()
    assert losses["l2c2"] > 0.0 and losses["entropy_coef"] == pytest.approx(0.002)  # annealed once: x0.5
    assert "reward_normalizer_state_dict" in algorithm.save()


def test_both_updates_switched_on_are_the_captured_one():
    both = composed(sync_free_update=True, captured_update=True)
    assert both.__mro__[1:3] == (CapturedUpdate, SyncFreeUpdate) and both.__name__ == "CapturedUpdatePPO"


def test_l2c2_with_rsl_rls_own_update_is_refused_naming_both():
    with pytest.raises(ConfigError, match=r"algorithm\.l2c2 cannot combine with rsl-rl's own update: it needs "
                                          r"algorithm\.sync_free_update or algorithm\.captured_update"):
        composed(l2c2={})


def test_a_ppo_extension_on_a_distillation_is_refused_naming_it():
    with pytest.raises(ConfigError, match=r"algorithm\.reward_normalization extends rsl-rl's PPO; this algorithm "
                                          r"is Distillation, a Distillation"):
        composed(class_name="Distillation", reward_normalization={})


def test_a_bad_setting_is_refused_naming_the_field():
    with pytest.raises(ConfigError, match="reward_normalization: unknown"):
        composed(reward_normalization={"decya": 0.9})


@pytest.mark.parametrize("old, mixins", [
    ("agile.rl_env.rsl_rl.sync_free_ppo:SyncFreePPO", (SyncFreeUpdate,)),
    ("agile.rl_env.rsl_rl.captured_ppo:CapturedPPO", (CapturedUpdate, SyncFreeUpdate)),
    ("agile.rl_env.rsl_rl.entropy_annealing:EntropyAnnealingPPO", (EntropyAnnealing,)),
])
def test_a_retired_class_name_loads_as_its_extension(old, mixins):
    """What checkpoints' overrides, the old `fast` recipe and the docs wrote, from a registered config."""
    _, agent_cfg = agile.tasks.load_cfgs("Velocity-T1-v0")
    apply_overrides({"agent": agent_cfg}, [f"agent.algorithm.class_name={old}"])
    cls = to_rsl_rl_dict(agent_cfg)["algorithm"]["class_name"]
    assert cls.__mro__[1:len(mixins) + 1] == mixins and cls.__mro__[len(mixins) + 1] is PPO


def test_the_retired_annealing_class_keeps_the_configs_settings():
    _, agent_cfg = agile.tasks.load_cfgs("PickPlace-G1-v0")
    apply_overrides({"agent": agent_cfg}, ["agent.algorithm.class_name=agile.rl_env.rsl_rl.entropy_annealing:"
                                           "EntropyAnnealingPPO"])
    algorithm = to_rsl_rl_dict(agent_cfg)["algorithm"]
    assert issubclass(algorithm["class_name"], EntropyAnnealing)
    assert algorithm["entropy_annealing"]["decay_per_iteration"] == 0.9998


def test_old_module_paths_of_models_and_distillation_load():
    _, agent_cfg = agile.tasks.load_cfgs("Velocity-Height-G1-Student-History-v0")
    apply_overrides({"agent": agent_cfg}, [
        "agent.algorithm.class_name=agile.rl_env.rsl_rl.distillation:Distillation",
        "agent.student.distribution_cfg.class_name=agile.rl_env.rsl_rl.distribution:SyncFreeGaussianDistribution"])
    d = to_rsl_rl_dict(agent_cfg)
    assert issubclass(d["algorithm"]["class_name"], MirrorLoss)  # the history student's mirror loss
    assert d["student"]["distribution_cfg"]["class_name"] == "agile.rl.distribution:SyncFreeGaussianDistribution"


def test_annealing_combines_with_the_sync_free_update_from_config():
    _, agent_cfg = agile.tasks.load_cfgs("PickPlace-G1-v0")
    apply_overrides({"agent": agent_cfg}, ["agent.algorithm.sync_free_update=true"])
    cls = to_rsl_rl_dict(agent_cfg)["algorithm"]["class_name"]
    assert cls.__mro__[1:3] == (EntropyAnnealing, SyncFreeUpdate)


def test_the_adapter_refuses_another_rsl_rl_version_naming_both():
    check_rsl_rl_version()  # the installed one: the pinned one
    with pytest.raises(RslRlVersionError, match=rf"rsl-rl-lib {RSL_RL_VERSION}'s internals.*rsl-rl-lib 5\.6\.0 is "
                                                rf"installed"):
        check_rsl_rl_version(installed="5.6.0")
