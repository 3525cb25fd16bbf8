"""Terms of pick-and-place tracking, which reads its reference as motion tracking does: the generic library, the
motion-tracking terms (anchor observations and rewards) and its own (palm, object, goal; the trajectory command)."""

from agile.tasks.motion_tracking.mdp import *  # noqa: F401,F403
from agile.tasks.pick_place.mdp.observations import *  # noqa: F401,F403
from agile.tasks.pick_place.mdp.palm import palm_pose_w  # noqa: F401
from agile.tasks.pick_place.mdp.rewards import *  # noqa: F401,F403
from agile.tasks.pick_place.mdp.terminations import *  # noqa: F401,F403
from agile.tasks.pick_place.mdp.tracking_command import TrackingCommand, TrackingCommandCfg  # noqa: F401
