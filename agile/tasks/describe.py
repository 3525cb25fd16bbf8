"""A task's MDP as it is resolved in a built env (`agile show`), and the flattened difference of two tasks'
configs (`agile diff`). Plain dicts, so that both print as YAML and compare in tests."""

from __future__ import annotations

from agile.rl_env.managers.term_cfg import SceneEntityCfg, index_list
from agile.utils.config import callable_name, to_dict


def _entity_selection(env, cfg: SceneEntityCfg) -> dict:
    """What a resolved selector selects: the entity, and the names its joint and body regexes matched."""
    entity = env.scene[cfg.name]
    out = {"entity": cfg.name}
    if cfg.joint_names is not None:
        names = entity.joint_names
        out["joints"] = [names[i] for i in index_list(cfg.joint_ids, len(names))]
    if cfg.body_names is not None:
        names = entity.body_names
        out["bodies"] = [names[i] for i in index_list(cfg.body_ids, len(names))]
    return out


def _params(env, params: dict) -> dict:
    return {key: _entity_selection(env, value) if isinstance(value, SceneEntityCfg) else to_dict(value)
            for key, value in params.items()}


def _term(env, term_cfg, **extra) -> dict:
    return {"func": callable_name(term_cfg.func), **extra, "params": _params(env, term_cfg.params)}


def _actions(env) -> dict:
    out = {}
    for name, term in env.action_manager.terms.items():
        entry = {"class": type(term).__name__, "entity": term.cfg.asset_name, "dim": term.action_dim}
        if hasattr(term, "joint_names"):
            entry["joints"] = list(term.joint_names)
        entry["cfg"] = {k: v for k, v in to_dict(term.cfg).items() if k not in ("class_type", "asset_name")}
        out[name] = entry
    return out


def _observations(env) -> dict:
    manager = env.observation_manager
    out = {}
    for group_name, group in manager.group_cfgs.items():
        terms = {}
        for name, term in manager.term_cfgs[group_name].items():
            length = group.history_length if group.history_length is not None else term.history_length
            terms[name] = {"dim": manager.term_dims[group_name][name], "history_length": length,
                           **_term(env, term), "scale": term.scale, "clip": to_dict(term.clip),
                           "noise": to_dict(term.noise) if group.enable_corruption else None}
        out[group_name] = {"dim": manager.group_dims[group_name], "concatenate_terms": group.concatenate_terms,
                           "terms": terms}
    return out


def _f32(value) -> float:
    """A float32 tensor entry as the number it was set to (0.2, not 0.20000000298023224)."""
    return float(f"{float(value):.6g}")


def _actuators(articulation) -> dict:
    """Per joint: its actuator group and model, and its gains and limits as built (before the startup randomisation
    draws, which scale these nominal values per world)."""
    group_of = {}
    for group_name, act in articulation.cfg.actuators.items():
        for i in articulation.find_joints(act.joint_names_expr)[0]:
            group_of.setdefault(i, (group_name, type(act).__name__))
    per_joint = {}
    for i, joint in enumerate(articulation.joint_names):
        group, model = group_of.get(i, (None, None))
        per_joint[joint] = {
            "group": group, "model": model,
            "stiffness_nm_per_rad": _f32(articulation.nominal_joint_stiffness[i]),
            "damping_nms_per_rad": _f32(articulation.nominal_joint_damping[i]),
            "effort_limit_nm": _f32(articulation.joint_effort_limit[0, i]),
            "velocity_limit_radps": _f32(articulation.joint_vel_limit[0, i]),
            "armature_kgm2": _f32(articulation.nominal_joint_armature[i]),
            "friction_nm": _f32(articulation.nominal_joint_friction[i]),
            "default_pos_rad": _f32(articulation.default_joint_pos[0, i]),
        }
    return per_joint


def resolved_mdp(env) -> dict:
    """Every term of a built single-agent env with its function, weight, params (entity selectors as the names
    they matched), the observation layout with dims, the actions with their joints, the actuators per joint."""
    cfg = env.cfg
    scene = env.scene
    return {
        "task": env.task_name,
        "num_envs": env.num_envs,
        "physics_dt_s": env.physics_dt_s, "step_dt_s": env.step_dt, "decimation": cfg.decimation,
        "episode_length_s": cfg.episode_length_s,
        "scene": {
            "entities": {name: {"class": type(e).__name__, "bodies": list(e.body_names),
                                "joints": list(getattr(e, "joint_names", []))} for name, e in scene.entities.items()},
            "contact_sensors": {name: {"bodies": list(getattr(s, "body_names", []))}
                                for name, s in scene.contact_sensors.items()},
            "height_scanners": sorted(scene.height_scanners),
            "terrain": to_dict(cfg.scene.terrain),
        },
        "commands": {name: {"class": type(term).__name__, "dim": int(term.command.shape[1]),
                            "cfg": {k: v for k, v in to_dict(term.cfg).items() if k != "class_type"}}
                     for name, term in env.command_manager.terms.items()},
        "actions": _actions(env),
        "observations": _observations(env),
        "rewards": {name: _term(env, t, weight=t.weight) for name, t in env.reward_manager.term_cfgs.items()},
        "terminations": {name: _term(env, t, time_out=t.time_out)
                         for name, t in env.termination_manager.term_cfgs.items()},
        "events": {name: _term(env, t, mode=t.mode, interval_range_s=to_dict(t.interval_range_s))
                   for name, t in env.event_manager.term_cfgs.items()},
        "curriculum": {name: _term(env, t) for name, t in env.curriculum_manager.term_cfgs.items()},
        "metrics": {name: _term(env, t, when=t.when) for name, t in env.metrics_manager.term_cfgs.items()},
        "actuators": {name: _actuators(a) for name, a in scene.articulations.items()},
    }


def flatten(tree, prefix: str = "") -> dict:
    """{'a.b.c': leaf} of nested dicts; lists are leaves (a joint list differs as a whole)."""
    if isinstance(tree, dict) and tree:
        out = {}
        for key, value in tree.items():
            out.update(flatten(value, f"{prefix}.{key}" if prefix else str(key)))
        return out
    return {prefix: tree}


MISSING = "<absent>"
"""What `config_diff` shows for a key path one config has and the other does not."""


def config_diff(a, b, prefix: str = "") -> dict:
    """{key path: (value in a, value in b)} where two nested configs differ, in a's key order then b's. A key
    that only one side has is one entry with its whole subtree against MISSING; lists are compared whole."""
    if not (isinstance(a, dict) and isinstance(b, dict)):
        return {} if a == b else {prefix: (a, b)}
    out = {}
    for key in [*a, *(k for k in b if k not in a)]:
        path = f"{prefix}.{key}" if prefix else str(key)
        if key not in a or key not in b:
            out[path] = (a.get(key, MISSING), b.get(key, MISSING))
        else:
            out.update(config_diff(a[key], b[key], path))
    return out


def task_config_tree(task: str) -> dict:
    """{'env': env cfg, 'agent': agent cfg} of a registered task as plain data (the task name left out)."""
    from agile.tasks import load_cfgs

    env_cfg, agent_cfg = load_cfgs(task)
    return {"env": to_dict(env_cfg), "agent": to_dict(agent_cfg)}
