"""LEAPP bundles, NVIDIA's deploy format (AGILE v1.3, Isaac Lab 3): raw robot state in, joint targets out.

A bundle is one folder per task, made with the `leapp` package: `<Task>.yaml`, `<Task>.onnx` and
`<Task>_initial_values.safetensors`. Unlike `policy.onnx` + `io_descriptor.yaml`, the graph holds everything between
the robot and its targets: each observation term (gravity projected from the root quaternion, joint positions
relative to the defaults, scale, clip, history), the observation normaliser, the network, the clamp of the raw action
and each action term's scale, offset and clip. A deployer feeds raw state; the graph's state (last action, histories,
a recurrent policy's hidden state) is fed back from one step to the next by LEAPP's runtime, from the initial values
at the start of an episode. Every input and output carries its semantic kind, its element names (joints in order) and
its Isaac Lab connection string; the YAML's pipeline configs hold the control frequency and the robot (actuator gains,
default joint positions, limits: the IO descriptor without its observation and action sections).

Built from the IO descriptor (what `agile.export.io_descriptor.io_descriptor` builds) and the actor's ONNX-ready
module, so that the bundle computes what `sim2mujoco.py` computes from the descriptor, by construction of the same rules.
"""

from __future__ import annotations

import os
import shutil

import torch

from agile.rl_env.io_descriptor_file import COMMAND_ELEMENTS
from agile.utils.math import quat_rotate_inverse
from agile.utils.output import quiet_python_output

# raw inputs: name -> (observation functions that read it, LEAPP kind, Isaac Lab connection)
RAW_INPUTS = {
    "joint_pos": (("joint_pos", "joint_pos_rel"), "state/joint/position", "state:robot:joint_pos"),
    "joint_vel": (("joint_vel_rel",), "state/joint/velocity", "state:robot:joint_vel"),
    "root_quat_w": (("projected_gravity",), "state/body/rotation", "state:robot:root_quat_w"),
    "root_lin_vel_b": (("base_lin_vel",), "state/body/linear_velocity", "state:robot:root_lin_vel_b"),
    "root_ang_vel_b": (("base_ang_vel",), "state/body/angular_velocity", "state:robot:root_ang_vel_b"),
    "command": (("generated_commands",), "command/body/velocity", None),
}
SUPPORTED_OBSERVATIONS = sorted({f for funcs, _, _ in RAW_INPUTS.values() for f in funcs} | {"last_action"})
ROBOT_KEYS = ("robot_model_file", "enable_all_colliders", "physics_dt_s", "decimation", "control_dt_s", "solver",
              "joint_names", "default_joint_pos", "default_root_height_m", "stiffness", "damping", "effort_limit",
              "velocity_limit", "armature", "friction", "actuators", "clip_actions")
"""The IO descriptor's robot and rates, kept in the bundle's configs for a simulator that rebuilds the robot."""
TARGET_OUTPUT = "joint_pos_target"


class UnsupportedPolicyError(ValueError):
    """The policy reads an observation that raw robot state cannot give (a height scan, a privileged term), or
    acts through something other than joint position targets."""


class DeployGraph(torch.nn.Module):
    """One control step from raw robot state, as plain torch: `forward(raw, state) -> (targets, new state)`.

    `raw` holds the tensors of `raw_inputs()`, each (1, dim); `state` those of `initial_state()`. The observation
    rules are the env's (`ObservationManager`): clip, then scale, then history (oldest first; a fresh history is
    filled with its first value); the action rules the env's (`ActionManager`): the raw output clamped to
    +-clip_actions, that clamped value is the next step's last action, targets = action * scale + offset, clipped."""

    def __init__(self, descriptor: dict, actor):
        super().__init__()
        self.joint_names = list(descriptor["joint_names"])
        index = {name: i for i, name in enumerate(self.joint_names)}
        self.register_buffer("default_joint_pos", torch.tensor(descriptor["default_joint_pos"]).unsqueeze(0))
        self.terms = [t for g in descriptor["observation_groups"] for t in descriptor["observations"][g]]
        unsupported = [f"{t['name']} ({t['func']})" for t in self.terms if t["func"] not in SUPPORTED_OBSERVATIONS]
        if unsupported:
            raise UnsupportedPolicyError(
                f"{descriptor['task']}: observation terms {unsupported} do not come from raw robot state; a bundle "
                f"builds these: {SUPPORTED_OBSERVATIONS}")
        not_targets = [f"{a['name']} ({a['type']})" for a in descriptor["actions"] if "offset" not in a]
        if not_targets:
            raise UnsupportedPolicyError(f"{descriptor['task']}: action terms {not_targets} are not joint position "
                                         f"targets (action * scale + offset)")
        for i, term in enumerate(self.terms):
            ids = [index[n] for n in term.get("joint_names", self.joint_names)]
            self.register_buffer(f"term{i}_joint_ids", torch.tensor(ids, dtype=torch.long))
        self.action_terms = descriptor["actions"]
        self.target_joint_names = [n for a in self.action_terms for n in a["joint_names"]]
        self.register_buffer("target_joint_ids", torch.tensor([index[n] for n in self.target_joint_names]))
        self.clip_actions = descriptor["clip_actions"]
        self.command_dim = next((t["dim"] for t in self.terms if t["func"] == "generated_commands"), 0)
        self.command_name = next((t.get("command_name") for t in self.terms if t["func"] == "generated_commands"), None)
        self.actor = actor
        self.recurrent_state = list(getattr(actor, "input_names", ["obs"])[1:])  # h_in (and c_in) of rsl-rl's export
        self.hidden_shape = (actor.num_layers, 1, actor.hidden_size) if self.recurrent_state else None

    # -- the interface -------------------------------------------------------------------------------------------

    def raw_inputs(self) -> list[tuple[str, int, str, list[str], str | None]]:
        """(name, dim, kind, element names, connection) of each raw input the observation terms read."""
        funcs = {t["func"] for t in self.terms}
        inputs = []
        for name, (readers, kind, connection) in RAW_INPUTS.items():
            if not funcs & set(readers):
                continue
            if name in ("joint_pos", "joint_vel"):
                elements = self.joint_names
            elif name == "root_quat_w":
                elements = ["qx", "qy", "qz", "qw"]
            elif name == "command":
                elements = list(COMMAND_ELEMENTS[:self.command_dim])
                connection = f"command:{self.command_name}"
            else:
                elements = ["x", "y", "z"]
            inputs.append((name, len(elements), kind, elements, connection))
        return inputs

    def initial_state(self) -> dict[str, torch.Tensor]:
        """The state at the start of an episode: zero last action, histories to be filled, zero hidden state."""
        state = {"last_action": torch.zeros(1, len(self.target_joint_names))}
        for term in self.terms:
            if term["history_length"] > 0:
                state[f"{term['name']}_history"] = torch.zeros(1, term["history_length"], term["dim"])
        if any(t["history_length"] > 0 for t in self.terms):
            state["history_started"] = torch.zeros(1, 1)
        for name in self.recurrent_state:
            state[name.removesuffix("_in")] = torch.zeros(self.hidden_shape)
        return state

    # -- one step ------------------------------------------------------------------------------------------------

    def _term_value(self, i: int, term: dict, raw: dict, last_action: torch.Tensor) -> torch.Tensor:
        ids = getattr(self, f"term{i}_joint_ids")
        func = term["func"]
        if func == "joint_pos_rel":
            return raw["joint_pos"][:, ids] - self.default_joint_pos[:, ids]
        if func == "joint_pos":
            return raw["joint_pos"][:, ids]
        if func == "joint_vel_rel":
            return raw["joint_vel"][:, ids]
        if func == "projected_gravity":
            quat = raw["root_quat_w"]
            return quat_rotate_inverse(quat, torch.tensor([0.0, 0.0, -1.0]).expand(quat.shape[0], 3))
        if func == "base_lin_vel":
            return raw["root_lin_vel_b"]
        if func == "base_ang_vel":
            return raw["root_ang_vel_b"]
        if func == "generated_commands":
            return raw["command"]
        return last_action  # "last_action"

    def forward(self, raw: dict[str, torch.Tensor], state: dict[str, torch.Tensor]):
        new_state = {}
        parts = []
        started = state.get("history_started")
        for i, term in enumerate(self.terms):
            value = self._term_value(i, term, raw, state["last_action"])
            if term["clip"] is not None:
                value = value.clamp(term["clip"][0], term["clip"][1])
            if term["scale"] is not None:
                value = value * torch.tensor(term["scale"])
            if term["history_length"] > 0:
                key = f"{term['name']}_history"
                rolled = torch.cat((state[key][:, 1:], value.unsqueeze(1)), dim=1)
                filled = value.unsqueeze(1).expand_as(rolled)
                history = torch.where(started.unsqueeze(-1) > 0.5, rolled, filled)
                new_state[key] = history
                value = history.flatten(1)
            parts.append(value)
        obs = torch.cat(parts, dim=-1)
        if self.recurrent_state:
            hidden = [state[name.removesuffix("_in")] for name in self.recurrent_state]
            action, *next_hidden = self.actor(obs, *hidden)
            for name, value in zip(self.recurrent_state, next_hidden):
                new_state[name.removesuffix("_in")] = value
        else:
            action = self.actor(obs)
        if self.clip_actions is not None:
            action = action.clamp(-self.clip_actions, self.clip_actions)
        new_state["last_action"] = action
        if started is not None:
            new_state["history_started"] = torch.ones_like(started)
        targets, start = [], 0
        for term in self.action_terms:
            n = len(term["joint_names"])
            target = action[:, start:start + n] * torch.tensor(term["scale"]) + torch.tensor(term["offset"])
            if "clip" in term:
                target = torch.clamp(target, torch.tensor(term["clip"][0]), torch.tensor(term["clip"][1]))
            targets.append(target)
            start += n
        return torch.cat(targets, dim=-1), new_state


def example_raw_inputs(graph: DeployGraph, generator: torch.Generator) -> dict[str, torch.Tensor]:
    """Plausible raw state (near the default pose, upright, a moderate command), for tracing the graph."""
    raw = {}
    for name, dim, _, _, _ in graph.raw_inputs():
        noise = torch.randn(1, dim, generator=generator)
        if name == "joint_pos":
            raw[name] = graph.default_joint_pos + 0.1 * noise
        elif name == "root_quat_w":
            quat = torch.tensor([[0.0, 0.0, 0.0, 1.0]]) + 0.05 * noise
            raw[name] = quat / quat.norm(dim=-1, keepdim=True)
        else:
            raw[name] = 0.5 * noise
    return raw


def _as_tuple(values) -> tuple:
    """LEAPP's annotations return one tensor for one entry, a tuple for several."""
    return tuple(values) if isinstance(values, (list, tuple)) else (values,)


def write_bundle(descriptor: dict, actor, out_dir: str, traced_steps: int = 3, seed: int = 0) -> str:
    """Trace `traced_steps` control steps of the policy (the rsl-rl actor's `as_onnx()` module, on the CPU) with LEAPP
    and write the bundle into `out_dir/<task>/`. Returns the YAML's path.

    The first traced step starts from `initial_state()`, which LEAPP stores as the initial values; the later ones
    from the graph's own state, so that LEAPP's check of the exported model sees the state change."""
    import leapp
    from leapp import GraphConfigs, TensorSemantics, annotate

    task = descriptor["task"]
    graph = DeployGraph(descriptor, actor.cpu().eval())
    bundle_dir = os.path.join(out_dir, task)
    shutil.rmtree(bundle_dir, ignore_errors=True)
    os.makedirs(out_dir, exist_ok=True)
    target_names = graph.target_joint_names
    gains = [TensorSemantics(name, torch.tensor(descriptor[key])[graph.target_joint_ids].unsqueeze(0), kind=kind,
                             element_names=target_names, extra={"isaaclab_connection": f"write:robot:{method}"})
             for name, key, kind, method in (
                 ("joint_pos_kp_gains", "stiffness", "kp", "write_joint_stiffness_to_sim_index"),
                 ("joint_pos_kd_gains", "damping", "kd", "write_joint_damping_to_sim_index"))]
    generator = torch.Generator().manual_seed(seed)
    state = graph.initial_state()
    with quiet_python_output():
        leapp.start(task, save_path=out_dir)
        try:
            with torch.no_grad():
                for _ in range(traced_steps):
                    raw = example_raw_inputs(graph, generator)
                    traced_raw = _as_tuple(annotate.input_tensors(task, [
                        TensorSemantics(name, raw[name], kind=kind, element_names=elements,
                                        extra={"isaaclab_connection": connection} if connection else None)
                        for name, _, kind, elements, connection in graph.raw_inputs()]))
                    traced_state = _as_tuple(annotate.state_tensors(task, state))
                    targets, state = graph(dict(zip(raw, traced_raw)), dict(zip(state, traced_state)))
                    annotate.update_state(task, state)
                    annotate.output_tensors(task, [TensorSemantics(
                        TARGET_OUTPUT, targets, kind="target/joint/position", element_names=target_names,
                        extra={"isaaclab_connection": "write:robot:set_joint_position_target_index"})],
                        static_outputs=gains, export_with="onnx")
        finally:
            leapp.stop()
        robot = {key: descriptor[key] for key in ROBOT_KEYS}
        leapp.compile_graph(visualize=False, graph_configs=GraphConfigs(
            frequency=1.0 / descriptor["control_dt_s"],
            extra={"task": task, "robot": robot, "commands": descriptor["commands"]}))
    log = os.path.join(bundle_dir, "log.txt")
    if os.path.exists(log):
        os.remove(log)
    return os.path.join(bundle_dir, f"{task}.yaml")
