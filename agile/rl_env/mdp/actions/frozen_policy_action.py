"""A frozen, exported locomotion policy as an action term (AGILE `AgileBasedLowerBodyAction`).

The task's policy outputs a 4-D lower-body command [vx, vy, wz, base height]; this term clips it to the ranges
the task allows, rebuilds the frozen policy's own observation from the robot (term by term, as the policy's IO
descriptor lists them: `agile/export/io_descriptor.py`), runs the TorchScript policy with no gradient, on the
env's device, and writes its leg targets. Nothing leaves the device, so the whole step stays capturable.

The observation is built as the policy was trained, not as the current task's robot defines it: joint
positions are relative to the descriptor's default pose, scales and clips are the descriptor's, and each term
keeps its own history per env (oldest first, refilled with the first value after a reset). No noise is
added: the frozen policy sees what a deployed one would.
"""

from __future__ import annotations

from dataclasses import field
from pathlib import Path

import torch

from agile.rl_env.managers import ActionTerm, ActionTermCfg, TermHistory
from agile.utils.config import configclass
from agile.utils.math import rounded_list

DATA_DIR = Path(__file__).resolve().parents[3] / "data" / "frozen_policies"
DEFAULT_FROZEN_POLICY = "Velocity-Height-G1-Teacher-v0"
"""AGILE freezes its velocity-height teacher (`unitree_g1_velocity_height_teacher.pt`) under pick-and-place."""
COMMAND_AXES = ("lin_vel_x", "lin_vel_y", "ang_vel_z", "base_height_m")
ROBOT_OBSERVATIONS = ("base_lin_vel", "base_ang_vel", "projected_gravity", "joint_pos_rel", "joint_vel_rel")
SUPPORTED_OBSERVATIONS = ("generated_commands", "last_action", *ROBOT_OBSERVATIONS)


def shipped_frozen_policy(task: str = DEFAULT_FROZEN_POLICY) -> tuple[str, str]:
    """(TorchScript file, IO descriptor) of a policy agile ships for freezing (made by scripts/export.py)."""
    folder = DATA_DIR / task
    if not folder.is_dir():
        shipped = sorted(p.name for p in DATA_DIR.iterdir() if p.is_dir()) if DATA_DIR.is_dir() else []
        raise FileNotFoundError(f"no frozen policy '{task}' under {DATA_DIR}. Shipped: {shipped}")
    return str(folder / "policy.pt"), str(folder / "io_descriptor.yaml")


def _read_descriptor(path: str) -> dict:
    from agile.rl_env.io_descriptor_file import read_io_descriptor

    return read_io_descriptor(path)


class FrozenPolicyAction(ActionTerm):
    """Action (N, 4): [vx m/s, vy m/s, wz rad/s, base height m], clipped to `command_ranges`; the frozen
    policy's output drives the descriptor's joints (target = output × scale + offset)."""

    def __init__(self, cfg: FrozenPolicyActionCfg, env):
        super().__init__(cfg, env)
        self.robot = env.scene[cfg.asset_name]
        device = env.device
        policy_file, descriptor_file = cfg.policy_file, cfg.io_descriptor_file
        if policy_file is None or descriptor_file is None:
            policy_file, descriptor_file = shipped_frozen_policy()
        if not str(policy_file).endswith(".pt"):
            raise ValueError(f"policy_file '{policy_file}': a TorchScript file (.pt, from scripts/export.py) is "
                             f"needed; an ONNX model runs on the host, outside the env's device step")
        descriptor = _read_descriptor(descriptor_file)
        where = f"frozen policy '{descriptor.get('task')}' ({descriptor_file})"
        self._check_descriptor(descriptor, where, env)

        unknown = sorted(set(cfg.command_ranges) - set(COMMAND_AXES))
        missing = [a for a in COMMAND_AXES if a not in cfg.command_ranges]
        if unknown or missing:
            raise ValueError(f"command_ranges: unknown axes {unknown}, missing {missing}; valid: {list(COMMAND_AXES)}")
        self.command_low = torch.tensor([cfg.command_ranges[a][0] for a in COMMAND_AXES], device=device)
        self.command_high = torch.tensor([cfg.command_ranges[a][1] for a in COMMAND_AXES], device=device)

        # the joints it drives: output × scale + offset (the descriptor's, i.e. the training task's defaults)
        action = descriptor["actions"][0]
        self.joint_names = list(action["joint_names"])
        self.joint_ids = self._robot_joint_ids(self.joint_names, where + " action")
        self.scale = torch.tensor(action["scale"], device=device)
        self.offset = torch.tensor(action["offset"], device=device)
        self.target_clip = None
        if action.get("clip") is not None:
            self.target_clip = (torch.tensor(action["clip"][0], device=device),
                                torch.tensor(action["clip"][1], device=device))

        # its observation, term by term
        self.default_pos = dict(zip(descriptor["joint_names"], descriptor["default_joint_pos"], strict=True))
        self.terms = [self._build_term(term, where, env) for group in descriptor["observation_groups"]
                      for term in descriptor["observations"][group]]

        self.policy = torch.jit.load(policy_file, map_location=device).eval()
        n = env.num_envs
        self.raw_actions = torch.zeros(n, 4, device=device)
        self.command = torch.zeros(n, 4, device=device)
        """(N, 4) the clipped command the frozen policy sees."""
        self.policy_action = torch.zeros(n, len(self.joint_names), device=device)
        """(N, J) the frozen policy's last output (clipped to ±policy_action_clip): its `last_action`."""
        self.processed_actions = self.robot.default_joint_pos[:, self.joint_ids].clone()
        self._check_policy_dims(where)

    # -- build time ------------------------------------------------------------------------------------

    def _check_descriptor(self, descriptor: dict, where: str, env) -> None:
        if descriptor["policy"]["recurrent"]:
            raise ValueError(f"{where}: a recurrent policy keeps one hidden state for one robot (batch 1); "
                             f"freeze a feed-forward policy (MLP, with or without observation history)")
        if len(descriptor["actions"]) != 1:
            raise ValueError(f"{where}: one action term expected, the descriptor has "
                             f"{[a['name'] for a in descriptor['actions']]}")
        if abs(descriptor["control_dt_s"] - env.step_dt) > 1e-9:
            raise ValueError(f"{where}: control_dt_s {descriptor['control_dt_s']} s != this env's step "
                             f"{env.step_dt} s; the policy must run at the rate it was trained at")

    def _robot_joint_ids(self, names: list[str], where: str) -> torch.Tensor:
        missing = [n for n in names if n not in self.robot.joint_names]
        if missing:
            raise ValueError(f"{where}: joints {missing} are not in robot '{self.cfg.asset_name}'. "
                             f"Its joints: {list(self.robot.joint_names)}")
        return torch.tensor([self.robot.joint_names.index(n) for n in names], dtype=torch.long,
                            device=self.env.device)

    def _build_term(self, term: dict, where: str, env) -> dict:
        func = term["func"]
        if func not in SUPPORTED_OBSERVATIONS:
            raise ValueError(f"{where}: observation '{term['name']}' uses '{func}', which a frozen policy cannot "
                             f"rebuild. Supported: {list(SUPPORTED_OBSERVATIONS)}")
        built = {"name": term["name"], "func": func, "scale": term["scale"], "clip": term["clip"], "history": None}
        if func == "generated_commands" and term["dim"] != 4:
            raise ValueError(f"{where}: command '{term['name']}' has {term['dim']} dimensions; the frozen lower body "
                             f"takes 4 {list(COMMAND_AXES)}")
        if func in ("joint_pos_rel", "joint_vel_rel"):
            names = term.get("joint_names") or list(self.default_pos)
            built["joint_ids"] = self._robot_joint_ids(names, f"{where} observation '{term['name']}'")
            built["default"] = torch.tensor([self.default_pos[n] for n in names], device=env.device)
        if term["history_length"] > 0:
            built["history"] = TermHistory(term["history_length"], env.num_envs, term["dim"], env.device)
        built["dim"] = term["dim"] * max(term["history_length"], 1)
        return built

    def _check_policy_dims(self, where: str) -> None:
        obs_dim = sum(t["dim"] for t in self.terms)
        with torch.no_grad():
            try:
                out = self.policy(torch.zeros(1, obs_dim, device=self.env.device))
            except RuntimeError as err:
                raise ValueError(f"{where}: the policy does not take the {obs_dim} observations its descriptor "
                                 f"lists: {str(err).strip().splitlines()[-1]}") from None
        if out.shape[-1] != len(self.joint_names):
            raise ValueError(f"{where}: the policy outputs {out.shape[-1]} actions, its descriptor names "
                             f"{len(self.joint_names)} joints")

    # -- every env step ------------------------------------------------------------------------------------

    def _term_value(self, term: dict) -> torch.Tensor:
        robot, func = self.robot, term["func"]
        if func == "generated_commands":
            return self.command
        if func == "last_action":
            return self.policy_action
        if func == "base_lin_vel":
            return robot.root_lin_vel_b
        if func == "base_ang_vel":
            return robot.root_ang_vel_b
        if func == "projected_gravity":
            return robot.projected_gravity_b
        if func == "joint_pos_rel":
            return robot.joint_pos[:, term["joint_ids"]] - term["default"]
        return robot.joint_vel[:, term["joint_ids"]]  # joint_vel_rel: the default joint velocity is 0

    def observation(self) -> torch.Tensor:
        """(N, D) the frozen policy's input now; pushes each history term once (call once per env step)."""
        values = []
        for term in self.terms:
            value = self._term_value(term)
            if term["clip"] is not None:
                value = value.clamp(term["clip"][0], term["clip"][1])
            if term["scale"] is not None:
                value = value * term["scale"]
            values.append(term["history"].push(value) if term["history"] is not None else value)
        return torch.cat(values, dim=-1)

    @property
    def action_dim(self) -> int:
        return 4

    def io_description(self) -> dict:
        """The action is the frozen lower-body policy's command [vx, vy, wz, height], clipped to these ranges; the
        frozen policy (its own IO descriptor) turns it into leg targets."""
        return {"type": type(self).__name__, "command_axes": list(COMMAND_AXES),
                "command_low": rounded_list(self.command_low), "command_high": rounded_list(self.command_high),
                "leg_joint_names": list(self.joint_names)}

    def process_actions(self, actions: torch.Tensor) -> None:
        self.raw_actions.copy_(actions)
        self.command.copy_(torch.maximum(torch.minimum(actions, self.command_high), self.command_low))
        with torch.no_grad():
            output = self.policy(self.observation())
        if self.cfg.policy_action_clip is not None:
            output = output.clamp(-self.cfg.policy_action_clip, self.cfg.policy_action_clip)
        self.policy_action.copy_(output)
        targets = output * self.scale + self.offset
        if self.target_clip is not None:
            targets = torch.maximum(torch.minimum(targets, self.target_clip[1]), self.target_clip[0])
        self.processed_actions.copy_(targets)

    def demonstration_action(self) -> tuple[list[str], torch.Tensor]:
        """The command to the frozen lower body [vx m/s, vy m/s, wz rad/s, height m], clipped to its ranges."""
        return list(COMMAND_AXES), self.command

    def apply_actions(self) -> None:
        self.robot.joint_pos_target[:, self.joint_ids] = self.processed_actions

    def reset(self, env_mask: torch.Tensor) -> None:
        m = env_mask.unsqueeze(-1)
        self.raw_actions.masked_fill_(m, 0.0)
        self.policy_action.masked_fill_(m, 0.0)
        for term in self.terms:
            if term["history"] is not None:
                term["history"].reset(env_mask)


@configclass
class FrozenPolicyActionCfg(ActionTermCfg):
    """AGILE `AgileLowerBodyActionCfg`. Leave both files None for the policy agile ships
    (`DEFAULT_FROZEN_POLICY`); else a TorchScript policy.pt and its io_descriptor.yaml from scripts/export.py."""

    class_type: type = FrozenPolicyAction
    policy_file: str | None = None
    io_descriptor_file: str | None = None
    command_ranges: dict[str, tuple[float, float]] = field(default_factory=lambda: {
        "lin_vel_x": (-0.2, 0.5), "lin_vel_y": (-0.4, 0.4), "ang_vel_z": (-0.5, 0.5), "base_height_m": (0.65, 0.72)})
    """Bounds of the command [m/s, m/s, rad/s, m] (AGILE's pick-and-place ranges)."""
    policy_action_clip: float | None = 6.0
    """The frozen policy's raw output is clipped to ±this before scaling, as its training clipped it (the
    Velocity-Height-G1 runner's `clip_actions`; the descriptor does not record it)."""
