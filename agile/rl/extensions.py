"""The one way to extend rsl-rl's algorithms: switched on from the agent config, composed into one class.

Every extension is a mixin class and a field of the algorithm config (`agile.rl.configs`): a flag (the sync-free and
the captured update), a settings dataclass (entropy annealing, reward normalisation, L2C2) or a weight (the
distillation mirror loss). `compose_algorithm` turns the algorithm config's dict into what rsl-rl takes: the class
named by `class_name` (rsl-rl's `PPO` or `Distillation`, or a subclass of them) with the mixins of the extensions
switched on in front, in the order of `EXTENSIONS` (outermost first); one class per combination, named after its
parts (e.g. `RewardNormalizationL2C2SyncFreeUpdatePPO`). The keys of the extensions left off are removed (rsl-rl's
constructors take no such argument).

The captured update is the sync-free update's mini-batch step replayed as a CUDA graph: its mixin derives from the
sync-free one, so switching both on is the captured update. What cannot combine is refused before any runner is built,
naming the fields:
- an extension without the one it works on (`needs_one_of`): L2C2 adds a term to the sync-free mini-batch step, so
  it needs the sync-free or the captured update (rsl-rl's own update has no place for it);
- an extension on an algorithm it does not extend (`extends`): a PPO extension on a distillation, and the reverse.

rsl-rl's own symmetry extension (`symmetry_cfg`: mirrored samples and PPO's mirror loss) is rsl-rl's, switched on by
its own config; the sync-free and captured updates compute it as rsl-rl's update does.
"""

from __future__ import annotations

import dataclasses
from functools import cache

from agile.utils.config import ConfigError, checked_cfg


@dataclasses.dataclass(frozen=True)
class Extension:
    key: str
    """The algorithm config's field that switches it on (a flag, settings, or a weight > 0)."""
    mixin: str
    """'module:Class' of the mixin put in front of the algorithm class."""
    extends: str
    """The rsl-rl algorithm it extends: "PPO" or "Distillation"."""
    settings: str | None = None
    """'module:Class' of its settings dataclass (with `check()`), checked here; None: no settings (a flag, a weight)."""
    also_takes: tuple[str, ...] = ()
    """Other fields of the algorithm config the mixin takes (removed with `key` when it is off)."""
    needs_one_of: tuple[str, ...] = ()
    """Extensions of which one must be on too."""
    passes_key: bool = True
    """Whether the mixin's constructor takes `key` (a flag's mixin needs no argument: the key goes)."""


EXTENSIONS = (
    Extension("entropy_annealing", "agile.rl.algorithms.entropy_annealing:EntropyAnnealing", "PPO",
              settings="agile.rl.configs:EntropyAnnealingCfg"),
    Extension("reward_normalization", "agile.rl.algorithms.reward_normalization:RewardNormalization", "PPO",
              settings="agile.rl.configs:RewardNormalizationCfg"),
    Extension("l2c2", "agile.rl.algorithms.l2c2:L2C2", "PPO", settings="agile.rl.configs:L2C2Cfg",
              needs_one_of=("sync_free_update", "captured_update")),
    Extension("captured_update", "agile.rl.algorithms.captured_update:CapturedUpdate", "PPO", passes_key=False),
    Extension("sync_free_update", "agile.rl.algorithms.sync_free_update:SyncFreeUpdate", "PPO", passes_key=False),
    Extension("mirror_loss_coeff", "agile.rl.algorithms.distillation:MirrorLoss", "Distillation",
              also_takes=("mirror_func",)),
)
"""Every extension, outermost first."""

def switched_on(value) -> bool:
    """A flag that is True, settings given (a dict, `{}` for the defaults), a weight above 0."""
    if value is None or value is False:
        return False
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return value > 0.0
    return True


def _resolve(name):
    from rsl_rl.utils import resolve_callable

    from agile.rl.compat import current_name

    return resolve_callable(current_name(name))


def _algorithm_kind(base: type) -> str:
    from rsl_rl.algorithms import PPO, Distillation

    for kind, cls in (("PPO", PPO), ("Distillation", Distillation)):
        if issubclass(base, cls):
            return kind
    raise ConfigError(f"algorithm.class_name: {base.__name__} is neither rsl-rl's PPO nor its Distillation (nor "
                      f"derived from them)")


def switched_on_extensions(algorithm: dict) -> list[Extension]:
    """The extensions `algorithm` (an algorithm config as a dict) switches on, checked: settings by their dataclass,
    and an extension without the one it needs refused, naming both fields."""
    on = [extension for extension in EXTENSIONS if switched_on(algorithm.get(extension.key))]
    names = {extension.key for extension in on}
    for extension in on:
        if extension.settings is not None:
            checked_cfg(_resolve(extension.settings), algorithm[extension.key], extension.key)
        if extension.needs_one_of and not names & set(extension.needs_one_of):
            needed = " or ".join(f"algorithm.{key}" for key in extension.needs_one_of)
            raise ConfigError(f"algorithm.{extension.key} cannot combine with rsl-rl's own update: it needs {needed} "
                              f"switched on (it adds a term to their mini-batch step)")
    return on


def compose_algorithm(algorithm: dict) -> None:
    """In place: `algorithm["class_name"]` becomes the configured class with the mixins of the extensions switched on
    in front (a class object: rsl-rl takes one as `class_name`; with none on, it stays as it is); the fields of those
    left off go, and so do the flags (their mixins take no argument). A bad field or combination raises ConfigError
    naming it."""
    on = switched_on_extensions(algorithm)
    for extension in EXTENSIONS:
        if extension not in on or not extension.passes_key:
            algorithm.pop(extension.key, None)
        if extension not in on:
            for key in extension.also_takes:
                algorithm.pop(key, None)
    if not on:  # rsl-rl resolves the class itself
        return
    base = _resolve(algorithm["class_name"])
    kind = _algorithm_kind(base)
    for extension in on:
        if extension.extends != kind:
            raise ConfigError(f"algorithm.{extension.key} extends rsl-rl's {extension.extends}; this algorithm is "
                              f"{base.__name__}, a {kind}")
    algorithm["class_name"] = extended(base, tuple(_resolve(extension.mixin) for extension in on))


@cache
def extended(base: type, mixins: tuple[type, ...]) -> type:
    """`base` with `mixins` in front, in order (outermost first); one class per combination (`base` itself for none).
    A mixin that `base` or another of `mixins` already derives from is not added again."""
    mixins = tuple(mixin for mixin in mixins if not issubclass(base, mixin)
                   and not any(other is not mixin and issubclass(other, mixin) for other in mixins))
    if not mixins:
        return base
    name = "".join(mixin.__name__ for mixin in mixins) + base.__name__
    return type(name, (*mixins, base), {"__doc__": f"{base.__name__} with {', '.join(m.__name__ for m in mixins)}."})
