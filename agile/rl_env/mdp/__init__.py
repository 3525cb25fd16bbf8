"""The generic term library, one module per kind: import as `from agile.rl_env import mdp` and use `mdp.<term>`.

Terms that one task family alone uses live with the family, in `agile/tasks/<family>/mdp/`, whose package re-exports
this library too: a task file imports its family's `mdp` and finds every term it can use there."""

from agile.rl_env.mdp.actions import *  # noqa: F401,F403
from agile.rl_env.mdp.commands import *  # noqa: F401,F403
from agile.rl_env.mdp.curriculums import *  # noqa: F401,F403
from agile.rl_env.mdp.events import *  # noqa: F401,F403
from agile.rl_env.mdp.observations import *  # noqa: F401,F403
from agile.rl_env.mdp.rewards import *  # noqa: F401,F403
from agile.rl_env.mdp.terminations import *  # noqa: F401,F403
from agile.rl_env.mdp.metrics import *  # noqa: F401,F403

from agile.rl_env.mdp import (actions as _actions, commands as _commands, curriculums as _curriculums,  # noqa: E402
                              events as _events, metrics as _metrics, observations as _observations,
                              rewards as _rewards, terminations as _terminations)

__all__ = sorted({name for module in (_actions, _commands, _curriculums, _events, _observations, _rewards,
                                      _terminations, _metrics) for name in module.__all__})
