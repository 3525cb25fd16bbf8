"""The names of classes and functions that configs, checkpoints, recipes and docs wrote before a module moved, mapped
to where they live now: the one place that keeps old `class_name` strings loading.

A checkpoint stores the run's overrides (`agent.algorithm.class_name=agile.rl_env.rsl_rl.captured_ppo:CapturedPPO`);
`to_rsl_rl_dict` passes every `class_name` through `current_name` before rsl-rl resolves it."""

from __future__ import annotations

MOVED_MODULES = {
    "agile.rl_env.rsl_rl.distribution": "agile.rl.distribution",
    "agile.rl_env.rsl_rl.distillation": "agile.rl.algorithms.distillation",
    "agile.rl_env.rsl_rl.sync_free_ppo": "agile.rl.algorithms.sync_free_ppo",
    "agile.rl_env.rsl_rl.captured_ppo": "agile.rl.algorithms.captured_ppo",
    "agile.rl_env.rsl_rl.entropy_annealing": "agile.rl.algorithms.entropy_annealing",
    "agile.rl_env.rsl_rl.reward_normalization": "agile.rl.algorithms.reward_normalization",
    "agile.rl_env.rsl_rl.l2c2": "agile.rl.algorithms.l2c2",
}
"""Module -> the module that holds its classes now (agile.rl_env.rsl_rl became agile.rl and agile.export)."""


def current_name(name):
    """`name` ("module:attr", or a class object, which passes through) with a moved module replaced by its new one."""
    if not isinstance(name, str):
        return name
    module, sep, attr = name.partition(":")
    return MOVED_MODULES.get(module, module) + sep + attr
