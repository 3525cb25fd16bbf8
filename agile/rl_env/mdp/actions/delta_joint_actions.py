"""Delta joint-position action (AGILE `DeltaJointPositionAction`): the action moves the joint targets.

target ← clip(target + action × scale), kept per env between steps, so a zero action holds the targets. At an
episode start the targets begin where the joints are (after the reset has placed them). The clip is the
joints' soft position limits narrowed by `joint_limits`. `steady_joint_names` are other joints of the robot that
no term drives here (the left arm under a right-handed task): they are held at their default positions.
"""

from __future__ import annotations

from dataclasses import field

import torch

from agile.rl_env.managers import ActionTerm, ActionTermCfg
from agile.sim.names import resolve_values
from agile.utils.config import configclass
from agile.utils.math import rounded_list


class DeltaJointPositionAction(ActionTerm):
    """Action (N, J): a step of each joint's target [rad / scale]."""

    def __init__(self, cfg: DeltaJointPositionActionCfg, env):
        super().__init__(cfg, env)
        self.robot = robot = env.scene[cfg.asset_name]
        joint_ids, self.joint_names = robot.find_joints(cfg.joint_names, preserve_order=True)
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=env.device)
        steady_ids = robot.find_joints(cfg.steady_joint_names)[0] if cfg.steady_joint_names else []
        overlap = sorted(set(steady_ids) & set(joint_ids))
        if overlap:
            raise ValueError(f"steady_joint_names: joints {[robot.joint_names[i] for i in overlap]} are also driven "
                             f"by joint_names; a joint is either driven or held")
        self.steady_ids = torch.tensor(steady_ids, dtype=torch.long, device=env.device)
        n, dim = env.num_envs, len(joint_ids)
        self.scale = torch.full((dim,), float(cfg.scale), device=env.device)
        soft = robot.soft_joint_pos_limits[:, self.joint_ids]
        self.low, self.high = soft[..., 0].clone(), soft[..., 1].clone()
        for i, low in resolve_values({k: v[0] for k, v in cfg.joint_limits.items()}, self.joint_names).items():
            self.low[:, i] = torch.clamp(self.low[:, i], min=low)
        for i, high in resolve_values({k: v[1] for k, v in cfg.joint_limits.items()}, self.joint_names).items():
            self.high[:, i] = torch.clamp(self.high[:, i], max=high)
        self.raw_actions = torch.zeros(n, dim, device=env.device)
        self.processed_actions = robot.default_joint_pos[:, self.joint_ids].clone()
        """(N, J) the joint targets [rad]."""
        self.start_from_joints = torch.ones(n, dtype=torch.bool, device=env.device)
        """(N,) the next step's targets start from the joints' positions (set at an episode start)."""

    @property
    def action_dim(self) -> int:
        return len(self.joint_ids)

    @property
    def base_targets(self) -> torch.Tensor:
        """(N, J) the targets the next action is added to [rad]: the current targets, or the joints' positions
        in envs that start an episode."""
        current = self.robot.joint_pos[:, self.joint_ids]
        return torch.where(self.start_from_joints.unsqueeze(-1), current, self.processed_actions)

    def actions_for_targets(self, targets: torch.Tensor) -> torch.Tensor:
        """(N, J) the action that moves the targets to `targets` [rad] in one step (before the clip): replaying
        a reference through this term (scripts/replay_pick_place_reference.py)."""
        return (targets - self.base_targets) / self.scale

    def process_actions(self, actions: torch.Tensor) -> None:
        self.raw_actions.copy_(actions)
        targets = self.base_targets
        self.processed_actions.copy_(torch.maximum(torch.minimum(targets + actions * self.scale, self.high),
                                                   self.low))
        self.start_from_joints.zero_()

    def io_description(self) -> dict:
        """Joint targets integrate the action: target += action · scale_rad_per_step, within [low, high] (env 0's
        limits); an episode starts from the measured joint positions."""
        return {"type": type(self).__name__, "joint_names": list(self.joint_names),
                "scale_rad_per_step": rounded_list(self.scale), "low": rounded_list(self.low[0]),
                "high": rounded_list(self.high[0])}

    def demonstration_action(self) -> tuple[list[str], torch.Tensor]:
        """The joint targets [rad] (absolute, as AGILE's recordings store them)."""
        return list(self.joint_names), self.processed_actions

    def apply_actions(self) -> None:
        self.robot.joint_pos_target[:, self.joint_ids] = self.processed_actions
        if len(self.steady_ids):
            self.robot.joint_pos_target[:, self.steady_ids] = self.robot.default_joint_pos[:, self.steady_ids]

    def reset(self, env_mask: torch.Tensor) -> None:
        self.raw_actions.masked_fill_(env_mask.unsqueeze(-1), 0.0)
        self.start_from_joints |= env_mask


@configclass
class DeltaJointPositionActionCfg(ActionTermCfg):
    class_type: type = DeltaJointPositionAction
    joint_names: list[str] = field(default_factory=list)
    """The driven joints (regexes, in this order)."""
    scale: float = 0.05
    """[rad] per unit of action per env step (AGILE: 0.05)."""
    joint_limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    """{joint regex: (low, high) [rad]} narrowing the soft position limits (AGILE: the waist's)."""
    steady_joint_names: list[str] | None = None
    """Joints held at their default positions (regexes); None: none."""
