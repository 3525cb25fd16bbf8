"""The IO descriptor of a trained policy, built from its env and agent config (the file's format, version, reading and
writing: `agile.rl_env.io_descriptor_file`, which the frozen-policy action term reads too).

The IO descriptor is everything a deployment (or `scripts/sim2mujoco.py`) needs to rebuild the policy's
inputs and apply its outputs without this framework: joints in policy order, defaults, action scale,
offset and clip, actuator gains and limits, every observation term in order with its scale, clip and
history length, the rates, and the model files' interface (for a recurrent policy: its hidden state).
"""

from __future__ import annotations

import os

from agile.rl_env.managers import ObsGroup, ObsTerm, SceneEntityCfg
from agile.rl_env.managers.manager_base import collect_terms
from agile.rl.configs import RnnModelCfg, policy_model_cfg, policy_obs_set
from agile.rl_env.io_descriptor_file import IO_DESCRIPTOR_VERSION
from agile.utils.config import callable_name
from agile.utils.math import rounded_list

# Tensor names of rsl-rl's ONNX export (rsl_rl.models: MLPModel.as_onnx, RNNModel.as_onnx)
ONNX_OBS_NAME, ONNX_ACTIONS_NAME = "obs", "actions"
ONNX_HIDDEN_STATE_NAMES = {"lstm": [("h_in", "h_out"), ("c_in", "c_out")], "gru": [("h_in", "h_out")]}


def _joint_names(robot, ids) -> list[str]:
    names = robot.joint_names
    return list(names) if isinstance(ids, slice) else [names[i] for i in ids.tolist()]


def _observation_terms(env, group_name: str) -> list[dict]:
    group: ObsGroup = env.observation_manager.group_cfgs[group_name]
    robot = env.scene[env.action_manager.policy_entity_name()]
    terms = []
    for name, term in collect_terms(group, ObsTerm).items():
        history = group.history_length if group.history_length is not None else term.history_length
        entry = {"name": name, "func": callable_name(term.func).split(":")[-1],
                 "dim": env.observation_manager.term_dims[group_name][name] // max(history, 1),
                 "scale": term.scale, "clip": list(term.clip) if term.clip else None, "history_length": history}
        for key, value in term.params.items():
            if isinstance(value, SceneEntityCfg):
                entry["joint_names"] = _joint_names(robot, value.joint_ids)
            else:
                entry[key] = value
        terms.append(entry)
    return terms


def _policy_interface(actor_cfg) -> dict:
    """The exported model's input and output names; for a recurrent actor also its hidden-state tensors, each
    (layers, batch 1, hidden) and fed from its output back to its input every step (zeros at episode start)."""
    interface = {"input": ONNX_OBS_NAME, "output": ONNX_ACTIONS_NAME, "recurrent": isinstance(actor_cfg, RnnModelCfg)}
    if interface["recurrent"]:
        shape = [actor_cfg.rnn_num_layers, 1, actor_cfg.rnn_hidden_dim]
        interface.update(rnn_type=actor_cfg.rnn_type, rnn_hidden_dim=actor_cfg.rnn_hidden_dim,
                         rnn_num_layers=actor_cfg.rnn_num_layers,
                         hidden_state=[{"input": name_in, "output": name_out, "shape": shape}
                                       for name_in, name_out in ONNX_HIDDEN_STATE_NAMES[actor_cfg.rnn_type]])
    return interface


def _plain(value) -> bool:
    """A number, flag, name or tuple of numbers: a command parameter another simulator can use."""
    if isinstance(value, tuple):
        return all(isinstance(v, (int, float)) for v in value)
    return isinstance(value, (int, float, bool, str))


def io_descriptor(env, agent_cfg) -> dict:
    """The IO descriptor of a policy trained on `env` (a ManagerBasedRLEnv) with `agent_cfg`."""
    robot = env.scene[env.action_manager.policy_entity_name()]
    actions = []
    training_only = env.action_manager.training_only_terms
    for name, term in env.action_manager.terms.items():
        # a term without action dimensions (random upper-body targets) is not part of the policy's output, nor is a
        # training-only aid (a lift, a harness), which exports run without
        if name in training_only or term.action_dim == 0:
            continue
        actions.append({"name": name, **term.io_description()})
    groups = agent_cfg.obs_groups[policy_obs_set(agent_cfg)]
    actuators = {}
    for group in robot.actuator_groups:
        entry = {"type": type(group.cfg).__name__, "joint_names": _joint_names(robot, group.joint_ids)}
        for key in ("min_delay", "max_delay"):
            if hasattr(group, key):
                entry[key] = int(getattr(group, key))
        if hasattr(group, "saturation_effort"):
            entry["saturation_effort"] = rounded_list(group.saturation_effort[0])
        actuators[group.name] = entry
    commands = {}
    for name, term in env.command_manager.terms.items():
        ranges = getattr(term.cfg, "ranges", None)
        commands[name] = {"type": type(term).__name__,
                          "ranges": {k: list(v) for k, v in vars(ranges).items()} if ranges is not None else None,
                          # how the command is drawn (standing share, walking height, ...), to draw alike elsewhere
                          "params": {k: list(v) if isinstance(v, tuple) else v for k, v in vars(term.cfg).items()
                                     if _plain(v) and k != "ranges"}}
    return {
        "version": IO_DESCRIPTOR_VERSION,
        "task": env.task_name,
        "robot_model_file": os.path.basename(robot.cfg.model_file),
        "enable_all_colliders": robot.cfg.enable_all_colliders,
        "physics_dt_s": env.physics_dt_s,
        "decimation": env.cfg.decimation,
        "control_dt_s": env.step_dt,
        "solver": {"iterations": env.sim.cfg.solver.iterations, "ls_iterations": env.sim.cfg.solver.ls_iterations,
                   "cone": env.sim.cfg.solver.cone, "impratio": env.sim.cfg.solver.impratio},
        "joint_names": list(robot.joint_names),
        "default_joint_pos": rounded_list(robot.default_joint_pos[0]),
        "default_root_height_m": float(robot.default_root_pose[0, 2]),
        # the nominal robot: world 0's values may be domain-randomised
        "stiffness": rounded_list(robot.nominal_joint_stiffness),
        "damping": rounded_list(robot.nominal_joint_damping),
        "effort_limit": rounded_list(robot.joint_effort_limit[0]),
        "velocity_limit": rounded_list(robot.joint_vel_limit[0]),
        "armature": rounded_list(robot.nominal_joint_armature),
        "friction": rounded_list(robot.nominal_joint_friction),
        "actuators": actuators,
        "actions": actions,
        # the env clamps the raw policy output to ±clip_actions before anything sees it (None: no clamp)
        "clip_actions": env.action_manager.clip_actions,
        "observation_groups": groups,
        "observations": {g: _observation_terms(env, g) for g in groups},
        "commands": commands,
        "policy": _policy_interface(policy_model_cfg(agent_cfg)),
    }
