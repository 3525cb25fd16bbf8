"""Left-right mirroring of observations and actions, for RSL-RL's symmetry augmentation.

Everything is derived from the robot and the observation terms, not from term names:
- joints and bodies pair up by swapping "left"/"right" (any case) in their names, else a quadruped's leg prefix
  (FL_ <-> FR_, RL_ <-> RR_, HL_ <-> HR_), else a side letter (T1's AL1 <-> AR1); a joint turning about its x or z axis
  (roll, yaw) changes sign, one turning about y (pitch) does not;
- an observation term is mirrored by what its function returns: polar vectors (linear velocity, gravity)
  flip y, pseudo-vectors (angular velocity) flip x and z, velocity commands flip vy and wz, joint terms and
  the last action use the joint map; a term function of a task family declares its own with `@mirrored_by`. A term
  without a rule is an error naming it.
Each group becomes one index permutation and one sign vector, built once: mirror(x) = x[:, perm] * sign.

Use in an agent config: `algorithm.symmetry_cfg = {"use_data_augmentation": True, "use_mirror_loss": False,
"mirror_loss_coeff": 0.0, "data_augmentation_func": "agile.rl_env.mdp.symmetry:lr_mirror"}`.
"""

from __future__ import annotations

import re
import weakref

import numpy as np
import torch
from tensordict import TensorDict

from agile.rl_env.managers import ObsTerm, SceneEntityCfg, index_list
from agile.rl_env.managers.manager_base import collect_terms
from agile.rl_env.mdp import observations as obs_terms

__all__ = ["GroupMirror", "body_mirror", "feet_scan_mirror", "group_mirror", "joint_mirror", "lr_mirror",
           "mirror_name", "mirror_within", "mirrored_by"]

POLAR_VECTOR = [1.0, -1.0, 1.0]
PSEUDO_VECTOR = [-1.0, 1.0, -1.0]
VELOCITY_COMMAND = [1.0, -1.0, -1.0]  # vx, vy, wz

_SIDE = re.compile(r"(left|right)", re.IGNORECASE)


def mirrored_by(perm: list[int], sign: list[float]):
    """Declare an observation term function's left-right mirror: its output (one step of it) mirrored is
    `x[perm] * sign`. For terms outside this module's table (a task family's own)."""
    def declare(func):
        func.lr_mirror = (list(perm), list(sign))
        return func
    return declare


def _swap_side(name: str) -> str:
    def swap(m):
        word = m.group(0)
        other = "right" if word.lower() == "left" else "left"
        return other.capitalize() if word[0].isupper() else other
    return _SIDE.sub(swap, name)


_SIDE_LETTER = re.compile(r"(?<=[A-Z])([LR])(?=\d)")
"""A side as one capital letter between a capital and a digit: T1's arm links AL1..AL3 / AR1..AR3."""
_LEG_PREFIX = re.compile(r"^([FRH])([LR])(?=_)")
"""A quadruped's leg as a prefix, front/rear (or hind) then left/right: Unitree's FL_hip_joint, RR_calf."""


def _other_letter(m: re.Match) -> str:
    return m.group(0)[:-1] + ("R" if m.group(0)[-1] == "L" else "L")


def mirror_name(name: str) -> str:
    """The name of the mirror joint or body: "left"/"right" swapped, else a leg prefix (FL_ <-> FR_), else a side
    letter (AL1 <-> AR1); a name with none of them is its own mirror (trunk, waist)."""
    for rule in (_swap_side, lambda n: _LEG_PREFIX.sub(_other_letter, n), lambda n: _SIDE_LETTER.sub(_other_letter, n)):
        partner = rule(name)
        if partner != name:
            return partner
    return name


def body_mirror(body_names: list[str]) -> list[int]:
    """The partner index of each body (`mirror_name`); a body without a side is its own partner (trunk, head,
    waist)."""
    index = {n: i for i, n in enumerate(body_names)}
    perm = []
    for name in body_names:
        partner = mirror_name(name)
        if partner not in index:
            raise ValueError(f"body '{name}' has no mirror body '{partner}'. Bodies: {body_names}")
        perm.append(index[partner])
    return perm


def joint_mirror(joint_names: list[str], joint_axes: np.ndarray) -> tuple[list[int], list[float]]:
    """(partner index, sign) per joint. joint_axes: (J, 3) joint axes in their local frames."""
    index = {n: i for i, n in enumerate(joint_names)}
    perm, sign = [], []
    for name, axis in zip(joint_names, joint_axes):
        partner = mirror_name(name)
        if partner not in index:
            raise ValueError(f"joint '{name}' has no mirror joint '{partner}'. Joints: {joint_names}")
        perm.append(index[partner])
        sign.append(1.0 if int(np.argmax(np.abs(axis))) == 1 else -1.0)
    return perm, sign


def mirror_within(ids: list[int], perm: list[int], sign: list[float]) -> tuple[list[int | None], list[float]]:
    """The joint mirror restricted to the joints `ids`: each one's partner as a position within `ids` (None
    where the partner is not among them) and its sign."""
    position = {j: k for k, j in enumerate(ids)}
    return [position.get(perm[j]) for j in ids], [sign[j] for j in ids]


def _sub_mirror(ids: list[int], perm: list[int], sign: list[float], what: str) -> tuple[list[int], list[float]]:
    """`mirror_within`, where every selected joint's partner must be selected too."""
    partners, signs = mirror_within(ids, perm, sign)
    missing = [j for j, p in zip(ids, partners) if p is None]
    if missing:
        raise ValueError(f"{what}: the mirror joints of joints {missing} are not selected too")
    return partners, signs


def feet_scan_mirror(left_offsets_b: torch.Tensor, right_offsets_b: torch.Tensor,
                     what: str) -> tuple[list[int], list[float]]:
    """Mirror of `height_scan_feet` (left rays, then right rays): the mirror of the left foot's ray at (x, y) in
    its foot's yaw frame is the right foot's ray at (x, -y), and the other way round; heights keep their sign."""
    num_left = left_offsets_b.shape[0]
    perm = []
    for offsets, partner_offsets, partner_start in ((left_offsets_b, right_offsets_b, num_left),
                                                    (right_offsets_b, left_offsets_b, 0)):
        reflected = offsets * torch.tensor([1.0, -1.0], device=offsets.device)
        match = torch.norm(reflected.unsqueeze(1) - partner_offsets.unsqueeze(0), dim=-1).min(dim=1)
        if (match.values > 1e-6).any():
            raise ValueError(f"{what}: the two foot scanners' ray grids are not mirror images in y")
        perm += [partner_start + k for k in match.indices.tolist()]
    return perm, [1.0] * len(perm)


class GroupMirror:
    """Permutation and signs mirroring the observation groups and the action of an env."""

    def __init__(self, env):
        robot = env.scene[env.action_manager.policy_entity_name()]
        axes = robot.joint_axis[0].cpu().numpy()
        self.joint_perm, self.joint_sign = joint_mirror(robot.joint_names, axes)
        action_perm, action_sign = [], []
        for name, term in env.action_manager.terms.items():
            if term.action_dim == 0:  # random upper-body targets: joints driven, no policy output
                continue
            p, s = _sub_mirror(term.joint_ids.tolist(), self.joint_perm, self.joint_sign, f"action term '{name}'")
            offset = len(action_perm)
            action_perm += [offset + k for k in p]
            action_sign += s
        self.action = (torch.tensor(action_perm, device=env.device), torch.tensor(action_sign, device=env.device))
        self.groups = {}
        for group_name, group in env.observation_manager.group_cfgs.items():
            perm, sign = [], []
            for term_name, term in collect_terms(group, ObsTerm).items():
                history = group.history_length if group.history_length is not None else term.history_length
                dim = env.observation_manager.term_dims[group_name][term_name] // max(history, 1)
                p, s = self._term_mirror(env, group_name, term_name, term, dim, action_perm, action_sign)
                for _ in range(max(history, 1)):
                    offset = len(perm)
                    perm += [offset + k for k in p]
                    sign += s
            self.groups[group_name] = (torch.tensor(perm, device=env.device), torch.tensor(sign, device=env.device))

    def _term_mirror(self, env, group_name, term_name, term, dim, action_perm, action_sign):
        func = term.func
        where = f"observation '{group_name}' term '{term_name}'"
        declared = getattr(func, "lr_mirror", None)
        if declared is not None:
            if len(declared[0]) != dim:
                raise ValueError(f"{where}: its declared mirror covers {len(declared[0])} values, the term gives {dim}")
            return declared
        if func in (obs_terms.base_lin_vel, obs_terms.projected_gravity):
            return [0, 1, 2], POLAR_VECTOR
        if func is obs_terms.base_ang_vel:
            return [0, 1, 2], PSEUDO_VECTOR
        if func is obs_terms.generated_commands and dim == 3:
            return [0, 1, 2], VELOCITY_COMMAND
        if func is obs_terms.generated_commands and dim == 4:  # a velocity and base-height command
            return [0, 1, 2, 3], [*VELOCITY_COMMAND, 1.0]
        if func is obs_terms.base_height_from_sensor:
            return [0], [1.0]
        if func is obs_terms.height_scan_feet:
            return feet_scan_mirror(env.scene[term.params["left_sensor_name"]].ray_offsets_b,
                                    env.scene[term.params["right_sensor_name"]].ray_offsets_b, where)
        if func in (obs_terms.joint_pos, obs_terms.joint_pos_rel, obs_terms.joint_vel_rel):
            asset: SceneEntityCfg = term.params["asset_cfg"]
            ids = index_list(asset.joint_ids, env.scene[asset.name].num_joints)
            return _sub_mirror(ids, self.joint_perm, self.joint_sign, where)
        if func is obs_terms.contact_force_norm:  # one magnitude per sensed body: the partner body's
            sensor_cfg: SceneEntityCfg = term.params["sensor_cfg"]
            sensor = env.scene[sensor_cfg.name]
            names = [sensor.body_names[i] for i in index_list(sensor_cfg.body_ids, len(sensor.body_names))]
            return body_mirror(names), [1.0] * len(names)
        if func is obs_terms.last_action and term.params.get("action_name") is None:
            return action_perm, action_sign
        raise ValueError(f"{where}: no mirror rule for '{func.__name__}'")

    @staticmethod
    def apply(x: torch.Tensor, perm_sign: tuple[torch.Tensor, torch.Tensor]) -> torch.Tensor:
        perm, sign = perm_sign
        return x[..., perm] * sign


_MIRRORS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def group_mirror(env) -> GroupMirror:
    """The (cached) mirror of a ManagerBasedRLEnv or of an RSL-RL wrapper around one."""
    env = getattr(env, "env", env)
    mirror = _MIRRORS.get(env)
    if mirror is None:
        mirror = _MIRRORS[env] = GroupMirror(env)
    return mirror


def lr_mirror(env, obs: TensorDict | None = None, actions: torch.Tensor | None = None):
    """RSL-RL augmentation: ([obs; mirrored obs], [actions; mirrored actions]); None stays None."""
    mirror = group_mirror(env)
    obs_aug = None
    if obs is not None:
        obs_aug = TensorDict({k: torch.cat((obs[k], mirror.apply(obs[k], mirror.groups[k])), dim=0) for k in obs.keys()},
                             batch_size=[obs.batch_size[0] * 2])
    actions_aug = None
    if actions is not None:
        actions_aug = torch.cat((actions, mirror.apply(actions, mirror.action)), dim=0)
    return obs_aug, actions_aug
