"""Joint position action: target = action × scale + offset, clipped, written to the PD targets."""

from __future__ import annotations

from dataclasses import field

import torch

from agile.rl_env.managers import ActionTerm, ActionTermCfg
from agile.sim.names import resolve_values
from agile.utils.config import configclass
from agile.utils.math import rounded_list


class JointPositionAction(ActionTerm):
    def __init__(self, cfg: JointPositionActionCfg, env):
        super().__init__(cfg, env)
        robot = env.scene[cfg.asset_name]
        self.robot = robot
        joint_ids, self.joint_names = robot.find_joints(cfg.joint_names, cfg.preserve_order)
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=env.device)
        n, dim = env.num_envs, len(joint_ids)
        self.scale = self._per_joint(cfg.scale, 1.0)
        self.offset = robot.default_joint_pos[:, self.joint_ids].clone() if cfg.use_default_offset \
            else torch.zeros(n, dim, device=env.device)
        self.clip = None
        if cfg.clip is not None:
            clip = cfg.clip if isinstance(cfg.clip, dict) else {".*": tuple(cfg.clip)}
            low = {k: v[0] for k, v in clip.items()}
            high = {k: v[1] for k, v in clip.items()}
            self.clip = (self._per_joint(low, -float("inf")), self._per_joint(high, float("inf")))
        self.raw_actions = torch.zeros(n, dim, device=env.device)
        self.processed_actions = self.offset.clone()

    def _per_joint(self, value, default: float) -> torch.Tensor:
        out = torch.full((len(self.joint_ids),), default, device=self.env.device)
        for i, v in resolve_values(value, self.joint_names).items():
            out[i] = v
        return out

    @property
    def action_dim(self) -> int:
        return len(self.joint_ids)

    def demonstration_action(self) -> tuple[list[str], torch.Tensor]:
        """The joint position targets [rad]."""
        return list(self.joint_names), self.processed_actions

    def actions_for_targets(self, targets: torch.Tensor) -> torch.Tensor:
        """(N, J) the action whose targets are `targets` [rad] (before the clip): the GUI's joint sliders."""
        return (targets - self.offset) / self.scale

    def process_actions(self, actions: torch.Tensor) -> None:
        self.raw_actions.copy_(actions)
        processed = actions * self.scale + self.offset
        if self.clip is not None:
            processed = torch.maximum(torch.minimum(processed, self.clip[1]), self.clip[0])
        self.processed_actions.copy_(processed)

    def io_description(self) -> dict:
        """Joint targets = action · scale + offset, clipped: per joint, as lists."""
        entry = {"type": type(self).__name__, "joint_names": list(self.joint_names),
                 "scale": rounded_list(self.scale), "offset": rounded_list(self.offset[0])}
        if self.clip is not None:
            entry["clip"] = [rounded_list(self.clip[0]), rounded_list(self.clip[1])]
        return entry

    def apply_actions(self) -> None:
        self.robot.joint_pos_target[:, self.joint_ids] = self.processed_actions

    def reset(self, env_mask: torch.Tensor) -> None:
        self.raw_actions.masked_fill_(env_mask.unsqueeze(-1), 0.0)


class RelativeJointPositionAction(JointPositionAction):
    """Isaac Lab `RelativeJointPositionAction`: target = the joint's current position + action × scale (+ offset,
    zero by default); `clip` bounds action × scale + offset, the step. A zero action holds the joints where they
    are. The target is set once per env step from the position then (Isaac Lab re-reads it every physics step)."""

    def actions_for_targets(self, targets: torch.Tensor) -> torch.Tensor:
        """(N, J) the step from where the joints are now to `targets` [rad] (before the clip)."""
        return (targets - self.robot.joint_pos[:, self.joint_ids] - self.offset) / self.scale

    def apply_actions(self) -> None:
        current = self.robot.joint_pos[:, self.joint_ids]
        self.robot.joint_pos_target[:, self.joint_ids] = self.processed_actions + current


@configclass
class JointPositionActionCfg(ActionTermCfg):
    """Isaac Lab semantics: `clip` bounds the processed target [rad], after scale and offset."""

    class_type: type = JointPositionAction
    joint_names: list[str] = field(default_factory=lambda: [".*"])
    scale: float | dict[str, float] = 1.0
    use_default_offset: bool = True
    clip: tuple[float, float] | dict[str, tuple[float, float]] | None = None
    preserve_order: bool = False


@configclass
class RelativeJointPositionActionCfg(JointPositionActionCfg):
    """Isaac Lab `RelativeJointPositionActionCfg` with `use_zero_offset=True`: the action is a step from where the
    joints are."""

    class_type: type = RelativeJointPositionAction
    use_default_offset: bool = False
