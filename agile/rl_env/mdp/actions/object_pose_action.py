"""Posing a kinematic rigid object by action: a hand-placed object for checking reward terms in a debug task."""

from __future__ import annotations

from dataclasses import field

import torch

from agile.rl_env.managers import ActionTerm, ActionTermCfg
from agile.utils.config import configclass
from agile.utils.math import quat_from_euler_xyz, quat_mul

AXES = ("x", "y", "z", "roll", "pitch", "yaw")


class ObjectPoseAction(ActionTerm):
    """Action (N, 6): position offset from the object's default pose [m] (env frame) and roll, pitch, yaw [rad]
    applied on top of its default orientation; each clipped to its range. Written as the object's root pose
    every env step, so the object stays where it is put (a kinematic body: gravity and contacts do not move it)."""

    def __init__(self, cfg: ObjectPoseActionCfg, env):
        super().__init__(cfg, env)
        self.object = env.scene[cfg.asset_name]
        body_type = getattr(self.object, "body_type", None)
        if body_type != "kinematic":
            raise ValueError(f"asset_name '{cfg.asset_name}': posing by action needs a kinematic rigid object "
                             f"(RigidObjectCfg(body_type='kinematic')); it is {body_type or 'an articulation'}")
        unknown = sorted(set(cfg.ranges) - set(AXES))
        if unknown:
            raise ValueError(f"ranges: unknown axes {unknown}; valid: {list(AXES)}")
        bad = {a: r for a, r in cfg.ranges.items() if not r[0] <= r[1]}
        if bad:
            raise ValueError(f"ranges: low > high for {bad}")
        self.low = torch.tensor([cfg.ranges.get(a, (-torch.inf, torch.inf))[0] for a in AXES], device=env.device)
        self.high = torch.tensor([cfg.ranges.get(a, (-torch.inf, torch.inf))[1] for a in AXES], device=env.device)
        self.raw_actions = torch.zeros(env.num_envs, 6, device=env.device)
        self.processed_actions = torch.zeros_like(self.raw_actions)
        self._all = torch.ones(env.num_envs, dtype=torch.bool, device=env.device)
        self._zero_velocity = torch.zeros(env.num_envs, 6, device=env.device)

    @property
    def action_dim(self) -> int:
        return 6

    def process_actions(self, actions: torch.Tensor) -> None:
        self.raw_actions.copy_(actions)
        self.processed_actions.copy_(torch.maximum(torch.minimum(actions, self.high), self.low))

    def apply_actions(self) -> None:
        offset = self.processed_actions
        pose = self.object.default_root_pose.clone()
        pose[:, :3] += offset[:, :3]
        pose[:, 3:7] = quat_mul(quat_from_euler_xyz(offset[:, 3], offset[:, 4], offset[:, 5]), pose[:, 3:7])
        self.object.write_root_state_env(pose, self._zero_velocity, self._all)

    def reset(self, env_mask: torch.Tensor) -> None:
        self.raw_actions.masked_fill_(env_mask.unsqueeze(-1), 0.0)
        self.processed_actions.masked_fill_(env_mask.unsqueeze(-1), 0.0)


@configclass
class ObjectPoseActionCfg(ActionTermCfg):
    class_type: type = ObjectPoseAction
    asset_name: str = "object"
    """A rigid object with body_type 'kinematic'."""
    ranges: dict[str, tuple[float, float]] = field(default_factory=dict)
    """Bounds per axis (x, y, z offsets [m]; roll, pitch, yaw [rad]); an axis not named is unbounded."""
