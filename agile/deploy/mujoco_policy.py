"""Policies as a robot runs them, from their exported files alone: `policy.pt` or `policy.onnx` with the IO
descriptor's observation and action rules (`DescriptorPolicy`), or a LEAPP bundle run by LEAPP's own runtime
(`BundlePolicy`). Each reads the MuJoCo state through `mujoco_robot.Robot`'s index maps and sets the robot's joint
targets; nothing of the training framework is used."""

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


class Observer:
    """The actor's input from the descriptor's observation terms: scale, clip, per-term history."""

    def __init__(self, descriptor: dict, robot: Robot):
        self.terms = [t for g in descriptor["observation_groups"] for t in descriptor["observations"][g]]
        self.robot = robot
        self.history = [deque(maxlen=max(t["history_length"], 1)) for t in self.terms]

    def reset(self) -> None:
        for h in self.history:
            h.clear()

    def _value(self, term: dict, data, command: np.ndarray, last_action: np.ndarray) -> np.ndarray:
        r = self.robot
        quat = data.qpos[3:7]
        ids = [r.index[n] for n in term.get("joint_names", r.d["joint_names"])]
        q = data.qpos[r.qpos_adr][ids]
        qd = data.qvel[r.dof_adr][ids]
        func = term["func"]
        if func == "base_lin_vel":
            return r.root_lin_vel_b(data)
        if func == "base_ang_vel":
            return data.qvel[3:6].copy()  # MuJoCo's free-joint angular velocity is in the body frame
        if func == "projected_gravity":
            return rotate_inverse(quat, np.array([0.0, 0.0, -1.0]))
        if func == "generated_commands":
            return command
        if func == "joint_pos_rel":
            return q - r.default_q[ids]
        if func == "joint_pos":
            return q
        if func == "joint_vel_rel":
            return qd
        if func == "last_action":
            return last_action
        raise ValueError(f"observation term '{term['name']}': function '{func}' is not supported by sim2mujoco")

    def __call__(self, data, command: np.ndarray, last_action: np.ndarray) -> np.ndarray:
        parts = []
        for term, history in zip(self.terms, self.history):
            value = np.asarray(self._value(term, data, command, last_action), dtype=np.float64)
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


class DescriptorPolicy:
    """policy.pt or policy.onnx driven by the IO descriptor's rules: the observation built by `Observer`, the raw
    action clamped to +-clip_actions (the env's ActionManager; the last-action observation is that clamped value),
    each action term's targets = action * scale + offset, clipped."""

    def __init__(self, descriptor: dict, robot: Robot, policy_path: str):
        self.robot = robot
        self.observer = Observer(descriptor, robot)
        self.policy = load_policy(policy_path, descriptor["policy"])
        self.action_terms = descriptor["actions"]
        self.clip_actions = descriptor.get("clip_actions")  # older descriptors: none
        self.action_dim = sum(len(a["joint_names"]) for a in self.action_terms)
        self.term_joint_ids = [[robot.index[n] for n in term["joint_names"]] for term in self.action_terms]
        self.reset()

    def reset(self) -> None:
        self.observer.reset()
        self.policy.reset()
        self.last_action = np.zeros(self.action_dim)

    def __call__(self, data, command: np.ndarray) -> None:
        action = np.asarray(self.policy(self.observer(data, command, self.last_action)), dtype=np.float64)
        if self.clip_actions is not None:
            action = np.clip(action, -self.clip_actions, self.clip_actions)
        self.last_action = action
        start = 0
        for term, ids in zip(self.action_terms, self.term_joint_ids):
            target = action[start:start + len(ids)] * np.array(term["scale"]) + np.array(term["offset"])
            start += len(ids)
            if "clip" in term:
                target = np.clip(target, term["clip"][0], term["clip"][1])
            self.robot.target[ids] = target


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

    QUAT_XYZW = [4, 5, 6, 3]  # of MuJoCo's free-joint qpos (w, x, y, z)

    def __init__(self, path: str, robot: Robot):
        self.robot = robot
        self.runtime = BundleRuntime(path)
        self.runtime.check_joints(robot.d["joint_names"])
        self.target_ids = [robot.index[n] for n in self.runtime.target_joints]

    def reset(self) -> None:
        self.runtime.reset()

    def raw_state(self, data, command: np.ndarray) -> dict:
        r = self.robot
        read = {"joint_pos": lambda: data.qpos[r.qpos_adr], "joint_vel": lambda: data.qvel[r.dof_adr],
                "root_quat_w": lambda: data.qpos[self.QUAT_XYZW], "root_lin_vel_b": lambda: r.root_lin_vel_b(data),
                "root_ang_vel_b": lambda: data.qvel[3:6], "command": lambda: command}
        return {name: read[name]() for name in self.runtime.inputs}  # only what the bundle reads

    def __call__(self, data, command: np.ndarray) -> None:
        outputs = self.runtime.run(self.raw_state(data, command))
        self.robot.target[self.target_ids] = outputs[self.runtime.target_name]
