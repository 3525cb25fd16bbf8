"""Sliders that drive an env's action terms by hand: a debug task's "policy".

For each action term the GUI knows how to drive, a folder of controls; `actions()` assembles the env's action
from them in term order, so the env is stepped exactly as a policy would step it:
- `JointPositionAction` and `DeltaJointPositionAction`: a slider per joint showing its target [rad] within the
  model's limits, grouped by limb, with buttons Reset (default pose and env reset), Zero all joints and Mirror
  left → right; the term turns the targets into its action (`actions_for_targets`: for a delta action, the step
  from its current targets);
- `MirroredJointPositionAction`: a line showing, from the simulation, the target of the last moved joint and
  the target the mirrored robot received for its partner joint;
- `ObjectPoseAction`: position [m] (env frame) and roll-pitch-yaw [rad] sliders;
- `FrozenPolicyAction`: the command to the frozen lower-body policy (vx, vy, wz, base height) within the term's
  ranges, with a Stand button.
Terms without a policy output need no controls; a term with one that has no controls is an error naming it.
Slider callbacks run on viser's threads and only record what was moved; the env is read and written on the
thread that steps it.
"""

from __future__ import annotations

import math
import re

import torch

from agile.rl_env.mdp.actions import (DeltaJointPositionAction, FrozenPolicyAction, JointPositionAction,
                                      MirroredJointPositionAction, ObjectPoseAction)
from agile.rl_env.mdp.actions.frozen_policy_action import COMMAND_AXES
from agile.rl_env.mdp.actions.object_pose_action import AXES
from agile.rl_env.mdp.symmetry import joint_mirror, mirror_within

LIMBS = (("leg", r"hip|knee|ankle|foot"), ("arm", r"shoulder|elbow|wrist"), ("hand", r"hand|finger|thumb|index|middle|palm"),
         ("waist", r"waist|torso|trunk"), ("head", r"head|neck"))
SIDE = re.compile(r"left|right", re.IGNORECASE)
SLIDER_STEP_RAD = 0.01


def limb_of(joint_name: str) -> str:
    """'left leg', 'right arm', 'waist', ... from a joint's name; 'other' when no limb word is in it."""
    name = joint_name.lower()
    part = next((limb for limb, words in LIMBS if re.search(words, name)), "other")
    side = SIDE.search(joint_name)
    return f"{side.group(0).lower()} {part}" if side and part != "other" else part


class JointSliders:
    """A slider per joint of a JointPositionAction or DeltaJointPositionAction term, showing the joint target [rad]."""

    def __init__(self, server, name: str, term: JointPositionAction | DeltaJointPositionAction,
                 mirror: MirroredJointPositionAction | None):
        self.term = term
        self.mirror = mirror
        robot = term.robot
        ids = term.joint_ids.tolist()
        limits = robot.joint_pos_limits[0, term.joint_ids].cpu()
        if isinstance(term, DeltaJointPositionAction):  # its targets are clipped narrower (e.g. AGILE's waist)
            limits = torch.stack((term.low[0], term.high[0]), dim=-1).cpu()
        self.default_targets = robot.default_joint_pos[0, term.joint_ids].cpu()
        perm, sign = joint_mirror(robot.joint_names, robot.joint_axis[0].cpu().numpy())
        self.partner, self.partner_sign = mirror_within(ids, perm, sign)
        # slider ranges: the targets the term can reach (the model's limits for a JointPositionAction); a joint
        # without limits turns a half circle either way
        self.low = [v if math.isfinite(v) else -math.pi for v in limits[:, 0].tolist()]
        self.high = [v if math.isfinite(v) else math.pi for v in limits[:, 1].tolist()]
        self.last_moved: int | None = None
        self.reset_requested = False
        groups: dict[str, list[int]] = {}
        for k, joint in enumerate(term.joint_names):
            groups.setdefault(limb_of(joint), []).append(k)
        with server.gui.add_folder(f"Joints: {name} ({term.cfg.asset_name})", order=2.0):
            reset = server.gui.add_button("Reset", hint="default pose, and reset the env")
            zero = server.gui.add_button("Zero all joints")
            mirror_lr = server.gui.add_button("Mirror left → right", hint="right joints take the left ones' mirror")
            self.readout = server.gui.add_markdown("Move a slider: the mirrored robot's target shows here.")
            by_index = {}
            for limb, members in groups.items():
                with server.gui.add_folder(limb, expand_by_default=len(groups) == 1):
                    for k in members:
                        slider = server.gui.add_slider(term.joint_names[k], min=self.low[k], max=self.high[k],
                                                       step=SLIDER_STEP_RAD,
                                                       initial_value=self._clamp(k, float(self.default_targets[k])))
                        slider.on_update(lambda _event, k=k: self._moved(k))
                        by_index[k] = slider
            self.sliders = [by_index[k] for k in range(len(term.joint_names))]
        reset.on_click(lambda _event: self._reset())
        zero.on_click(lambda _event: self.set_targets([0.0] * len(self.sliders)))
        mirror_lr.on_click(lambda _event: self.mirror_left_to_right())

    def _clamp(self, k: int, value: float) -> float:
        return min(max(value, self.low[k]), self.high[k])

    def _moved(self, k: int) -> None:
        self.last_moved = k

    def _reset(self) -> None:
        self.set_targets(self.default_targets.tolist())
        self.reset_requested = True

    def targets(self) -> list[float]:
        return [float(s.value) for s in self.sliders]

    def set_targets(self, values: list[float]) -> None:
        for k, (slider, value) in enumerate(zip(self.sliders, values)):
            slider.value = self._clamp(k, float(value))

    def mirror_left_to_right(self) -> None:
        """Each right joint takes its left partner's target through the mirror (sign flipped for roll and
        yaw); joints on the centre line keep only what a symmetric pose allows (a waist roll goes to 0)."""
        values = self.targets()
        names = self.term.joint_names
        new = list(values)
        for k, name in enumerate(names):
            p = self.partner[k]
            if p is None:
                continue
            side = SIDE.search(name)
            if side and side.group(0).lower() == "right":
                new[k] = self.partner_sign[k] * values[p]
            elif not side:
                new[k] = 0.5 * (values[k] + self.partner_sign[k] * values[p])
        self.set_targets(new)

    def actions(self) -> torch.Tensor:
        """(num_envs, dim) the term's action that gives the sliders' targets, in every env."""
        env = self.term.env
        return self.term.actions_for_targets(torch.tensor(self.targets(), device=env.device).expand(env.num_envs, -1))

    def update(self) -> None:
        """Show the last moved joint's target and its mirror's, both read from the simulation."""
        k = self.last_moved
        if k is None or self.mirror is None:
            return
        names = self.term.joint_names
        p = self.partner[k]
        source = float(self.term.robot.joint_pos_target[0, self.term.joint_ids[k]])
        mirrored = float(self.mirror.robot.joint_pos_target[0, self.term.joint_ids[p]])
        self.readout.content = (f"**{self.term.cfg.asset_name}** `{names[k]}`: {source:+.3f} rad → "
                                f"**{self.mirror.cfg.asset_name}** `{names[p]}`: {mirrored:+.3f} rad")


class ObjectPoseSliders:
    """Position [m] (env frame) and roll, pitch, yaw [rad] of an object posed by an ObjectPoseAction term."""

    def __init__(self, server, name: str, term: ObjectPoseAction):
        self.default_pos = term.object.default_root_pose[0, :3].cpu()  # the default pose is env-relative
        low, high = term.low.cpu().tolist(), term.high.cpu().tolist()
        self.sliders = []
        with server.gui.add_folder(f"Object: {name} ({term.cfg.asset_name})", order=3.0):
            for i, axis in enumerate(AXES):
                base = float(self.default_pos[i]) if i < 3 else 0.0
                lo, hi = (max(low[i], -math.pi) if i >= 3 else low[i]), (min(high[i], math.pi) if i >= 3 else high[i])
                if not (math.isfinite(lo) and math.isfinite(hi)):
                    lo, hi = -1.0, 1.0  # an unbounded position axis: a metre either way
                unit = "m" if i < 3 else "rad"
                self.sliders.append(server.gui.add_slider(f"{axis} [{unit}]", min=base + lo, max=base + hi, step=0.005,
                                                          initial_value=base))

    def actions(self) -> torch.Tensor:
        values = torch.tensor([float(s.value) for s in self.sliders])
        values[:3] -= self.default_pos
        return values

    def reset(self) -> None:
        for i, slider in enumerate(self.sliders):
            slider.value = float(self.default_pos[i]) if i < 3 else 0.0


class CommandSliders:
    """The command a FrozenPolicyAction term gives its frozen lower-body policy: [vx m/s, vy m/s, wz rad/s, base
    height m] within the term's ranges. Stand (and every env reset) puts it back to standing: no velocity (0, or
    the range's bound nearest to it) at the highest base height allowed."""

    def __init__(self, server, name: str, term: FrozenPolicyAction):
        low, high = term.command_low.tolist(), term.command_high.tolist()
        self.standing = [min(max(0.0, lo), hi) for lo, hi in zip(low[:3], high[:3])] + [high[3]]
        with server.gui.add_folder(f"Command: {name} ({term.cfg.asset_name})", order=2.5):
            stand = server.gui.add_button("Stand", hint="no velocity, the highest base height allowed")
            self.sliders = [server.gui.add_slider(axis, min=lo, max=hi, step=0.01, initial_value=value)
                            for axis, lo, hi, value in zip(COMMAND_AXES, low, high, self.standing)]
        stand.on_click(lambda _event: self.reset())

    def actions(self) -> torch.Tensor:
        return torch.tensor([float(s.value) for s in self.sliders])

    def reset(self) -> None:
        for slider, value in zip(self.sliders, self.standing):
            slider.value = value


class ActionSliders:
    """Controls for every action term of `env` that takes a policy output; `actions()` is the env's action."""

    def __init__(self, server, env):
        self.env = env
        terms = env.action_manager.terms
        mirrors = {t.cfg.source_action_name: t for t in terms.values() if isinstance(t, MirroredJointPositionAction)}
        self.parts = []
        for name, term in terms.items():
            if isinstance(term, (JointPositionAction, DeltaJointPositionAction)):
                self.parts.append(JointSliders(server, name, term, mirrors.get(name)))
            elif isinstance(term, ObjectPoseAction):
                self.parts.append(ObjectPoseSliders(server, name, term))
            elif isinstance(term, FrozenPolicyAction):
                self.parts.append(CommandSliders(server, name, term))
            elif term.action_dim > 0:
                raise ValueError(f"action term '{name}' ({type(term).__name__}) has no GUI controls; sliders drive "
                                 f"JointPositionAction, DeltaJointPositionAction, ObjectPoseAction and "
                                 f"FrozenPolicyAction terms")
        self.joints = [p for p in self.parts if isinstance(p, JointSliders)]

    @property
    def reset_requested(self) -> bool:
        return any(p.reset_requested for p in self.joints)

    def after_reset(self) -> None:
        """The env was reset: object sliders back to their default pose and commands to standing too; reset
        requests consumed."""
        for part in self.parts:
            if isinstance(part, (ObjectPoseSliders, CommandSliders)):
                part.reset()
            else:
                part.reset_requested = False

    def actions(self) -> torch.Tensor:
        """(num_envs, action dim) on the env's device; every env receives the sliders' targets and commands (a part
        gives one row, or one per env where its action depends on the env's state)."""
        n, device = self.env.num_envs, self.env.device
        return torch.cat([p.actions().to(device).expand(n, -1) for p in self.parts], dim=-1).float()

    def update(self) -> None:
        for part in self.joints:
            part.update()
