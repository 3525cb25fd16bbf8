"""The shared term library: import as `from agile.rl_env import mdp` and use `mdp.<term>` in task files."""

from agile.rl_env.mdp.actions import *  # noqa: F401,F403
from agile.rl_env.mdp.commands import *  # noqa: F401,F403
from agile.rl_env.mdp.curriculums import *  # noqa: F401,F403
from agile.rl_env.mdp.events import *  # noqa: F401,F403
from agile.rl_env.mdp.observations import *  # noqa: F401,F403
from agile.rl_env.mdp.rewards import *  # noqa: F401,F403
from agile.rl_env.mdp.rewards_velocity_height import *  # noqa: F401,F403
from agile.rl_env.mdp.terminations import *  # noqa: F401,F403
from agile.rl_env.fallen_states.reset import *  # noqa: F401,F403
from agile.rl_env.mdp.rewards_stand_up import *  # noqa: F401,F403
from agile.rl_env.mdp.curriculums_stand_up import *  # noqa: F401,F403
from agile.rl_env.mdp.rewards_height_tracking import *  # noqa: F401,F403
from agile.rl_env.mdp.terminations_height_tracking import *  # noqa: F401,F403
from agile.rl_env.mdp.curriculums_height_tracking import *  # noqa: F401,F403
from agile.rl_env.mdp.motion_tracking import *  # noqa: F401,F403
from agile.rl_env.mdp.pick_place import *  # noqa: F401,F403
from agile.rl_env.mdp.metrics import *  # noqa: F401,F403
