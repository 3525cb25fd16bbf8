"""Terms of motion tracking (BeyondMimic): the generic library and the terms that compare the robot with a
`MotionCommand`'s reference, and that command."""

from agile.rl_env.mdp import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.events import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.motion_command import MotionCommand, MotionCommandCfg  # noqa: F401
from agile.tasks.motion_tracking.mdp.observations import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.reference import quat_error_magnitude  # noqa: F401
from agile.tasks.motion_tracking.mdp.rewards import *  # noqa: F401,F403
from agile.tasks.motion_tracking.mdp.terminations import *  # noqa: F401,F403

from agile.rl_env import mdp as _generic  # noqa: E402
from agile.tasks.motion_tracking.mdp import (events as _events, observations as _observations,  # noqa: E402
                                             rewards as _rewards, terminations as _terminations)

__all__ = sorted({*_generic.__all__, *_events.__all__, *_observations.__all__, *_rewards.__all__,
                  *_terminations.__all__, "quat_error_magnitude", "MotionCommand",
                  "MotionCommandCfg"})
