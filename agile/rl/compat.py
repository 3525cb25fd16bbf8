"""The names that configs, checkpoints, recipes and docs wrote before the RL glue moved (agile.rl_env.rsl_rl became
agile.rl and agile.export) and before PPO's extensions became config switches: the one place that keeps old
`class_name` strings loading.

A checkpoint stores the run's overrides (`agent.algorithm.class_name=agile.rl_env.rsl_rl.captured_ppo:CapturedPPO`,
what the `fast` recipe wrote); `to_rsl_rl_dict` passes every `class_name` through here before rsl-rl resolves it:
a moved module is replaced by its new one (`current_name`), and a class that was one way to extend PPO becomes the
class it extended with the extension's switch on (`with_current_names`)."""

from __future__ import annotations

MOVED_MODULES = {"agile.rl_env.rsl_rl.distribution": "agile.rl.distribution"}
"""Module -> the module that holds its classes now (for `class_name` strings of classes that still exist)."""

RETIRED_CLASSES = {
    "agile.rl_env.rsl_rl.sync_free_ppo:SyncFreePPO": ("PPO", {"sync_free_update": True}),
    "agile.rl_env.rsl_rl.captured_ppo:CapturedPPO": ("PPO", {"captured_update": True}),
    "agile.rl_env.rsl_rl.entropy_annealing:EntropyAnnealingPPO": ("PPO", {"entropy_annealing": {}}),
    "agile.rl_env.rsl_rl.distillation:Distillation": ("Distillation", {}),
}
"""A class that extended rsl-rl's algorithm by subclassing it -> (that algorithm, the extension switches that do what
it did; the distillation's mirror loss is switched by its weight, as before). A switch the config already turns on is
kept as it is (its settings included)."""


def current_name(name):
    """`name` ("module:attr", or a class object, which passes through) with a moved module replaced by its new one."""
    if not isinstance(name, str):
        return name
    module, sep, attr = name.partition(":")
    return MOVED_MODULES.get(module, module) + sep + attr


def with_current_names(algorithm: dict) -> dict:
    """In place (and returned): an algorithm config dict's `class_name` as it is named now, a retired class replaced
    by the algorithm it extended and its extension's switch."""
    name = algorithm["class_name"]
    base, switches = RETIRED_CLASSES.get(name, (current_name(name), {}))
    algorithm["class_name"] = base
    for key, value in switches.items():
        if algorithm.get(key) in (None, False):
            algorithm[key] = value
    return algorithm
