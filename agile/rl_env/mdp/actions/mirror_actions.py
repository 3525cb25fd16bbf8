"""An articulation that copies another action term's joint targets through the left-right mirror.

A check of the symmetry functions by eye: a second robot receives the first one's joint targets mirrored by
the same joint map that symmetry augmentation uses (`agile.rl_env.mdp.symmetry.joint_mirror`), so a wrong
pairing or sign shows as a pose that is not the mirror image.
"""

from __future__ import annotations

import torch

from agile.rl_env.managers import ActionTerm, ActionTermCfg
from agile.rl_env.mdp.actions.joint_actions import JointPositionAction
from agile.rl_env.mdp.symmetry import joint_mirror, mirror_within
from agile.utils.config import configclass


class MirroredJointPositionAction(ActionTerm):
    """No policy output of its own: every env step, `asset_name`'s joint targets are the source term's
    processed targets, permuted to the partner joints and sign-flipped for roll and yaw joints."""

    def __init__(self, cfg: MirroredJointPositionActionCfg, env):
        super().__init__(cfg, env)
        self.robot = env.scene[cfg.asset_name]

    def link(self, terms: dict) -> None:
        source = terms.get(self.cfg.source_action_name)
        if not isinstance(source, JointPositionAction):
            raise ValueError(f"source_action_name '{self.cfg.source_action_name}' must name a JointPositionAction "
                             f"term; terms: {sorted(terms)}")
        if self.robot.joint_names != source.robot.joint_names:
            raise ValueError(f"'{self.cfg.asset_name}' has joints {self.robot.joint_names}, not those of "
                             f"'{source.cfg.asset_name}' {source.robot.joint_names}")
        perm, sign = joint_mirror(source.robot.joint_names, source.robot.joint_axis[0].cpu().numpy())
        partners, signs = mirror_within(source.joint_ids.tolist(), perm, sign)
        unpaired = [name for name, p in zip(source.joint_names, partners) if p is None]
        if unpaired:
            raise ValueError(f"the mirror joints of {unpaired} are not driven by '{self.cfg.source_action_name}'")
        self.source = source
        # mirrored target of joint k = signs[k] * the source's target of its partner partners[k]
        self.partner_positions = torch.tensor(partners, device=self.env.device)
        self.partner_signs = torch.tensor(signs, device=self.env.device)
        self.joint_ids = source.joint_ids
        self.joint_names = source.joint_names
        self.partner_names = [source.joint_names[p] for p in partners]
        """The source joint each mirrored joint copies, in the source term's joint order."""

    @property
    def action_dim(self) -> int:
        return 0

    def process_actions(self, actions: torch.Tensor) -> None:
        pass

    def mirrored_targets(self) -> torch.Tensor:
        """(N, J) the mirrored robot's targets [rad], in the source term's joint order."""
        return self.source.processed_actions[:, self.partner_positions] * self.partner_signs

    def apply_actions(self) -> None:
        self.robot.joint_pos_target[:, self.joint_ids] = self.mirrored_targets()


@configclass
class MirroredJointPositionActionCfg(ActionTermCfg):
    class_type: type = MirroredJointPositionAction
    asset_name: str = "mirrored_robot"
    """The articulation that receives the mirrored targets (the same model as the source's)."""
    source_action_name: str = "joint_pos"
    """The JointPositionAction term whose targets are mirrored."""
