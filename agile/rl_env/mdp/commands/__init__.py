from agile.rl_env.mdp.commands.height_command import SmoothHeightCommand, SmoothHeightCommandCfg, SmoothHeightRangesCfg
from agile.rl_env.mdp.commands.motion_command import MotionCommand, MotionCommandCfg
from agile.rl_env.mdp.commands.tracking_command import TrackingCommand, TrackingCommandCfg
from agile.rl_env.mdp.commands.velocity_command import (UniformNullVelocityCommand, UniformNullVelocityCommandCfg,
                                                        VelocityRangesCfg)
from agile.rl_env.mdp.commands.velocity_height_command import (UniformVelocityBaseHeightCommand,
                                                               UniformVelocityBaseHeightCommandCfg,
                                                               VelocityHeightRangesCfg)

__all__ = ["MotionCommand", "MotionCommandCfg", "SmoothHeightCommand", "SmoothHeightCommandCfg", "SmoothHeightRangesCfg",
           "TrackingCommand", "TrackingCommandCfg", "UniformNullVelocityCommand", "UniformNullVelocityCommandCfg",
           "UniformVelocityBaseHeightCommand", "UniformVelocityBaseHeightCommandCfg", "VelocityHeightRangesCfg",
           "VelocityRangesCfg"]
