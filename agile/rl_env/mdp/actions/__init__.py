from agile.rl_env.mdp.actions.joint_actions import JointPositionAction, JointPositionActionCfg
from agile.rl_env.mdp.actions.random_actions import (RandomActionCfg, RandomPositionAction, TrapezoidalProfile,
                                                     TrapezoidalVelocityProfileCfg)

__all__ = ["JointPositionAction", "JointPositionActionCfg", "RandomActionCfg", "RandomPositionAction",
           "TrapezoidalProfile", "TrapezoidalVelocityProfileCfg"]
