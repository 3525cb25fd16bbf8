from agile.rl_env.mdp.commands.velocity_command import (UniformNullVelocityCommand, UniformNullVelocityCommandCfg,
                                                        VelocityRangesCfg)

__all__ = ["UniformNullVelocityCommand", "UniformNullVelocityCommandCfg", "VelocityRangesCfg"]
