from agile.rl_env.mdp.commands.height_command import SmoothHeightCommand, SmoothHeightCommandCfg, SmoothHeightRangesCfg
from agile.rl_env.mdp.commands.velocity_command import (UniformNullVelocityCommand, UniformNullVelocityCommandCfg,
                                                        VelocityRangesCfg)
from agile.rl_env.mdp.commands.velocity_height_command import (UniformVelocityBaseHeightCommand,
                                                               UniformVelocityBaseHeightCommandCfg,
                                                               VelocityHeightRangesCfg)

__all__ = ["SmoothHeightCommand", "SmoothHeightCommandCfg", "SmoothHeightRangesCfg",
           "UniformNullVelocityCommand", "UniformNullVelocityCommandCfg",
           "UniformVelocityBaseHeightCommand", "UniformVelocityBaseHeightCommandCfg", "VelocityHeightRangesCfg",
           "VelocityRangesCfg"]
