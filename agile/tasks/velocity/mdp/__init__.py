"""Terms of the velocity tasks (`Velocity-*`, and `Velocity-Height-*`, which build on them): the generic library and
the velocity family's own rewards (yaw-frame tracking, standing still on a null command, base height)."""

from agile.rl_env.mdp import *  # noqa: F401,F403
from agile.tasks.velocity.mdp.rewards import *  # noqa: F401,F403
