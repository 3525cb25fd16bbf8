"""Terms of the stand-up tasks: the generic library and the family's own rewards (while standing) and curricula (the
adaptive lift, terrain levels by standing at the time-out)."""

from agile.rl_env.mdp import *  # noqa: F401,F403
from agile.tasks.stand_up.mdp.curriculums import *  # noqa: F401,F403
from agile.tasks.stand_up.mdp.rewards import *  # noqa: F401,F403
