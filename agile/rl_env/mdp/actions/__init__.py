from agile.rl_env.mdp.actions.joint_actions import JointPositionAction, JointPositionActionCfg

__all__ = ["JointPositionAction", "JointPositionActionCfg"]
