"""A PPO class with extension mixins in front (reward normalisation, L2C2): the class `to_rsl_rl_dict` gives rsl-rl
for an algorithm config that sets them (`runner_cfg.EXTENSIONS`)."""

from __future__ import annotations

from functools import cache

from agile.utils.config import ConfigError


@cache
def extended(base: type, mixins: tuple[type, ...]) -> type:
    """`base` with `mixins` in front, in order (outermost first); one class per combination. A mixin that needs a
    kind of base (`needs_base`, e.g. L2C2's extra loss term needs SyncFreePPO's mini-batch step) is refused with
    any other, naming both."""
    for mixin in mixins:
        needed = getattr(mixin, "needs_base", None)
        if needed is not None and not issubclass(base, needed):
            raise ConfigError(f"{mixin.__name__} needs a PPO class derived from {needed.__name__} (e.g. "
                              f"agent.algorithm.class_name=agile.rl.algorithms.sync_free_ppo:SyncFreePPO or "
                              f"...captured_ppo:CapturedPPO); got {base.__name__}")
    mixins = tuple(mixin for mixin in mixins if not issubclass(base, mixin))
    if not mixins:
        return base
    name = "".join(mixin.__name__ for mixin in mixins) + base.__name__
    return type(name, (*mixins, base), {"__doc__": f"{base.__name__} with {', '.join(m.__name__ for m in mixins)}."})
