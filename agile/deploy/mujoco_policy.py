"""Policies as a robot runs them, from their exported files alone: `policy.pt` or `policy.onnx` with the IO
descriptor's observation and action rules (`DescriptorRuntime`), or a LEAPP bundle run by LEAPP's own runtime
(`BundleRuntime`, agile/deploy/leapp_runtime.py). Both read raw state (joint encoders, the root's orientation and
velocities, the command: `RAW_INPUT_OF_TERM`), so that `agile deploy` feeds them from a robot's SDK; on the MuJoCo
state (`mujoco_raw_state`, `mujoco_robot.Robot`'s index maps) `DescriptorPolicy` and `BundlePolicy` set the robot's
joint targets. Nothing of the training framework is used."""

from __future__ import annotations

from collections import deque
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from agile.errors import AgileError
from agile.deploy.mujoco_robot import rotate_inverse
from agile.deploy.leapp_runtime import BundleRuntime

if TYPE_CHECKING:
    from agile.deploy.mujoco_robot import Robot


def yaml_load(path: str) -> dict:
    import yaml

    return yaml.safe_load(Path(path).read_text())


RAW_INPUT_OF_TERM = {"base_lin_vel": "root_lin_vel_b", "base_ang_vel": "root_ang_vel_b",
                     "projected_gravity": "root_quat_w", "generated_commands": "command", "joint_pos_rel": "joint_pos",
                     "joint_pos": "joint_pos", "joint_vel_rel": "joint_vel", "last_action": None}
"""The observation functions an exported policy may read, each with the raw input it is computed from (the names
of a LEAPP bundle's inputs; the last action is the runtime's own)."""


class Observer:
    """The actor's input from the descriptor's observation terms on raw state (`RAW_INPUT_OF_TERM`'s inputs: joint
    positions and velocities in the descriptor's joint order, the root's orientation (x, y, z, w) and body-frame
    velocities, the command): scale, clip, per-term history."""

    def __init__(self, descriptor: dict):
        self.terms = [t for g in descriptor["observation_groups"] for t in descriptor["observations"][g]]
        unsupported = [f"{t['name']} ({t['func']})" for t in self.terms if t["func"] not in RAW_INPUT_OF_TERM]
        if unsupported:
            raise ValueError(f"observation terms {unsupported}: an exported policy may read "
                             f"{', '.join(RAW_INPUT_OF_TERM)}")
        index = {n: i for i, n in enumerate(descriptor["joint_names"])}
        self.joint_ids = [[index[n] for n in t.get("joint_names", descriptor["joint_names"])] for t in self.terms]
        self.default_q = np.array(descriptor["default_joint_pos"])
        self.inputs = tuple(sorted({RAW_INPUT_OF_TERM[t["func"]] for t in self.terms} - {None}))
        """The raw inputs the observation reads."""
        self.history = [deque(maxlen=max(t["history_length"], 1)) for t in self.terms]

    def reset(self) -> None:
        for h in self.history:
            h.clear()

    def _value(self, term: dict, ids: list, raw: dict, last_action: np.ndarray) -> np.ndarray:
        func = term["func"]
        if func == "base_lin_vel":
            return raw["root_lin_vel_b"]
        if func == "base_ang_vel":
            return raw["root_ang_vel_b"]
        if func == "projected_gravity":
            return rotate_inverse(np.asarray(raw["root_quat_w"])[[3, 0, 1, 2]], np.array([0.0, 0.0, -1.0]))
        if func == "generated_commands":
            return raw["command"]
        if func == "joint_pos_rel":
            return np.asarray(raw["joint_pos"])[ids] - self.default_q[ids]
        if func == "joint_pos":
            return np.asarray(raw["joint_pos"])[ids]
        if func == "joint_vel_rel":
            return np.asarray(raw["joint_vel"])[ids]
        return last_action

    def __call__(self, raw: dict, last_action: np.ndarray) -> np.ndarray:
        parts = []
        for term, ids, history in zip(self.terms, self.joint_ids, self.history):
            value = np.asarray(self._value(term, ids, raw, last_action), dtype=np.float64)
            if term["clip"] is not None:
                value = np.clip(value, *term["clip"])
            if term["scale"] is not None:
                value = value * term["scale"]
            if not history:
                history.extend([value] * history.maxlen)  # a fresh history repeats the first value
            else:
                history.append(value)
            parts.extend(history)
        return np.concatenate(parts).astype(np.float32)


def mujoco_raw_state(robot: Robot, data, command: np.ndarray) -> dict:
    """The raw inputs (`RAW_INPUT_OF_TERM`'s names) from the MuJoCo state: the descriptor's joints, the free joint."""
    return {"joint_pos": data.qpos[robot.qpos_adr], "joint_vel": data.qvel[robot.dof_adr],
            "root_quat_w": data.qpos[[4, 5, 6, 3]],  # MuJoCo's free joint holds (w, x, y, z)
            "root_lin_vel_b": robot.root_lin_vel_b(data),
            "root_ang_vel_b": data.qvel[3:6].copy(),  # MuJoCo's free-joint angular velocity is in the body frame
            "command": command}


class OnnxPolicy:
    """An ONNX policy stepped once per control step. A recurrent one gets its hidden state back every step
    (names and shapes from the descriptor's "policy" section), zeros at reset(). `session` is anything with
    ONNX Runtime's run(output_names, feeds): onnx's ReferenceEvaluator (no extra dependency) or onnxruntime's."""

    def __init__(self, session, interface: dict):
        self.session = session
        self.interface = interface
        self.hidden = interface.get("hidden_state", [])
        self.reset()

    def reset(self) -> None:
        self.state = {h["input"]: np.zeros(h["shape"], dtype=np.float32) for h in self.hidden}

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        names = [self.interface["output"]] + [h["output"] for h in self.hidden]
        action, *state = self.session.run(names, {self.interface["input"]: obs[None], **self.state})
        self.state = {h["input"]: value for h, value in zip(self.hidden, state)}
        return action[0]


class TorchScriptPolicy:
    """A TorchScript policy stepped once per control step; a recurrent one keeps its hidden state inside."""

    def __init__(self, path: str):
        import torch

        self.torch = torch
        self.module = torch.jit.load(path, map_location="cpu")

    def reset(self) -> None:
        self.module.reset()  # zeros a recurrent policy's hidden state (a no-op for an MLP)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        with self.torch.no_grad():
            return self.module(self.torch.from_numpy(obs)[None]).numpy()[0]


def load_policy(path: str, interface: dict):
    """policy.onnx or policy.pt as a callable obs -> action with reset() for the start of an episode."""
    if path.endswith(".onnx"):
        from onnx.reference import ReferenceEvaluator

        return OnnxPolicy(ReferenceEvaluator(path), interface)
    return TorchScriptPolicy(path)


class DescriptorRuntime:
    """policy.pt or policy.onnx driven by the IO descriptor's rules, from raw state: the observation built by
    `Observer`, the raw action clamped to +-clip_actions (the env's ActionManager; the last-action observation is that
    clamped value), each action term's targets = action * scale + offset, clipped. `target_joints` are the action
    terms' joints, in the order of the targets returned. What `DescriptorPolicy` (MuJoCo) and `agile.deploy` share."""

    def __init__(self, descriptor: dict, policy_path: str, onnx_session_factory=None):
        """`onnx_session_factory(path)`: the `InferenceSession` (or anything with its run()) a policy.onnx runs in (default: onnx's ReferenceEvaluator, no
        extra dependency)."""
        self.observer = Observer(descriptor)
        self.inputs = self.observer.inputs
        if policy_path.endswith(".onnx") and onnx_session_factory is not None:
            self.policy = OnnxPolicy(onnx_session_factory(policy_path), descriptor["policy"])
        else:
            self.policy = load_policy(policy_path, descriptor["policy"])
        self.action_terms = descriptor["actions"]
        self.clip_actions = descriptor.get("clip_actions")  # older descriptors: none
        self.target_joints = [n for term in self.action_terms for n in term["joint_names"]]
        self.reset()

    def reset(self) -> None:
        self.observer.reset()
        self.policy.reset()
        self.last_action = np.zeros(len(self.target_joints))

    def __call__(self, raw: dict) -> np.ndarray:
        """Targets [rad] of `target_joints`."""
        action = np.asarray(self.policy(self.observer(raw, self.last_action)), dtype=np.float64)
        if self.clip_actions is not None:
            action = np.clip(action, -self.clip_actions, self.clip_actions)
        self.last_action = action
        targets, start = [], 0
        for term in self.action_terms:
            n = len(term["joint_names"])
            target = action[start:start + n] * np.array(term["scale"]) + np.array(term["offset"])
            start += n
            if "clip" in term:
                target = np.clip(target, term["clip"][0], term["clip"][1])
            targets.append(target)
        return np.concatenate(targets)

    def targets_and_gains(self, raw: dict) -> tuple:
        """(targets [rad] of `target_joints`, None, None): a descriptor's policy outputs no gains."""
        return self(raw), None, None


class DescriptorPolicy:
    """A `DescriptorRuntime` on the MuJoCo state: sets the robot's joint targets."""

    def __init__(self, descriptor: dict, robot: Robot, policy_path: str):
        self.robot = robot
        self.runtime = DescriptorRuntime(descriptor, policy_path)
        self.target_ids = [robot.index[n] for n in self.runtime.target_joints]

    def reset(self) -> None:
        self.runtime.reset()

    def __call__(self, data, command: np.ndarray) -> None:
        self.robot.target[self.target_ids] = self.runtime(mujoco_raw_state(self.robot, data, command))


def read_bundle(path: str) -> dict:
    """A LEAPP bundle's YAML (`agile export --format leapp`), checked to be one this script can run."""
    import yaml

    bundle = yaml.safe_load(Path(path).read_text())
    configs = bundle.get("pipeline", {}).get("configs", {})
    if "robot" not in configs or "task" not in configs:
        raise AgileError(f"{path}: not a LEAPP bundle written by agile export --format leapp (its pipeline configs "
                         f"name no robot and task)")
    return bundle


def bundle_descriptor(bundle: dict) -> dict:
    """The robot, rates and commands of a bundle, in the IO descriptor's keys (what `run` reads)."""
    configs = bundle["pipeline"]["configs"]
    return {"task": configs["task"], **configs["robot"], "commands": configs["commands"]}


class BundlePolicy:
    """A LEAPP bundle (`BundleRuntime`) on the MuJoCo state: raw MuJoCo state in, the robot's joint position
    targets out."""

    def __init__(self, path: str, robot: Robot):
        self.robot = robot
        self.runtime = BundleRuntime(path)
        self.runtime.check_joints(robot.d["joint_names"])
        self.target_ids = [robot.index[n] for n in self.runtime.target_joints]

    def reset(self) -> None:
        self.runtime.reset()

    def __call__(self, data, command: np.ndarray) -> None:
        raw = mujoco_raw_state(self.robot, data, command)
        outputs = self.runtime.run({name: raw[name] for name in self.runtime.inputs})
        self.robot.target[self.target_ids] = outputs[self.runtime.target_name]
