"""Terms of the stand-up tasks: the generic library and the family's own rewards (while standing) and curricula (the
adaptive lift, terrain levels by standing at the time-out) and the reset from the fallen-state dataset."""

from agile.rl_env.mdp import *  # noqa: F401,F403
from agile.tasks.stand_up.mdp.curriculums import *  # noqa: F401,F403
from agile.tasks.stand_up.mdp.rewards import *  # noqa: F401,F403
from agile.tasks.stand_up.fallen_states.reset import *  # noqa: F401,F403

from agile.rl_env import mdp as _generic  # noqa: E402
from agile.tasks.stand_up.fallen_states import reset as _reset  # noqa: E402
from agile.tasks.stand_up.mdp import curriculums as _curriculums, rewards as _rewards  # noqa: E402

__all__ = sorted({*_generic.__all__, *_curriculums.__all__, *_rewards.__all__, *_reset.__all__})
