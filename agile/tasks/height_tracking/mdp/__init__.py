"""Terms of the height-tracking task, which builds on stand-up: the generic library, the stand-up family's terms and
its own (height tracking, the lift's decay, penalty ramps, invalid states)."""

from agile.tasks.height_tracking.mdp.curriculums import *  # noqa: F401,F403
from agile.tasks.height_tracking.mdp.rewards import *  # noqa: F401,F403
from agile.tasks.height_tracking.mdp.terminations import *  # noqa: F401,F403
from agile.tasks.stand_up.mdp import *  # noqa: F401,F403
