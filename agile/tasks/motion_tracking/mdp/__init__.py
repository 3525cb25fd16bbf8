"""Terms of motion tracking (BeyondMimic): the generic library and the terms that compare the robot with a
`MotionCommand`'s reference."""

from agile.rl_env.mdp import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.events import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.observations import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.reference import quat_error_magnitude  # noqa: F401
from agile.tasks.motion_tracking.mdp.rewards import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.terminations import *  # noqa: F401,F403
