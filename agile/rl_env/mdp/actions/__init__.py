from agile.rl_env.mdp.actions.delta_joint_actions import DeltaJointPositionAction, DeltaJointPositionActionCfg
from agile.rl_env.mdp.actions.frozen_policy_action import FrozenPolicyAction, FrozenPolicyActionCfg
from agile.rl_env.mdp.actions.harness_action import HarnessAction, HarnessActionCfg
from agile.rl_env.mdp.actions.joint_actions import (JointPositionAction, JointPositionActionCfg,
                                                    RelativeJointPositionAction, RelativeJointPositionActionCfg)
from agile.rl_env.mdp.actions.lift_action import LiftAction, LiftActionCfg
from agile.rl_env.mdp.actions.mirror_actions import MirroredJointPositionAction, MirroredJointPositionActionCfg
from agile.rl_env.mdp.actions.object_pose_action import ObjectPoseAction, ObjectPoseActionCfg
from agile.rl_env.mdp.actions.random_actions import (RandomActionCfg, RandomPositionAction, TrapezoidalProfile,
                                                     TrapezoidalVelocityProfileCfg)

__all__ = ["HarnessAction", "HarnessActionCfg", "JointPositionAction", "JointPositionActionCfg",
           "LiftAction", "LiftActionCfg",
           "RelativeJointPositionAction", "RelativeJointPositionActionCfg",
           "MirroredJointPositionAction", "MirroredJointPositionActionCfg", "ObjectPoseAction", "ObjectPoseActionCfg",
           "RandomActionCfg", "RandomPositionAction", "TrapezoidalProfile", "TrapezoidalVelocityProfileCfg"]
__all__ += ["DeltaJointPositionAction", "DeltaJointPositionActionCfg", "FrozenPolicyAction", "FrozenPolicyActionCfg"]
