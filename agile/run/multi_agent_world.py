"""A multi-agent world built and stepped for training and evaluation, by either trainer (per-group PPO in
agile/run/multi_agent.py, HAPPO in agile/run/happo.py): the world's build, its evaluation settings, the actions of the
agents acting at a step, and the per-agent evaluation."""

from __future__ import annotations

from agile.run import task_setup
from agile.run.policy import inference_cfg


def make_world(task: str, env_cfg, device: str):
    world = task_setup.make_env(task=task, env_cfg=env_cfg, device=device)
    print(f"[agile] agents {list(world.agents)}; schedule (physics steps, {world.physics_dt_s * 1000:g} ms): "
          f"{world.schedule.describe()}")
    return world


def evaluation_cfg(env_cfg, pushes: bool):
    """Every agent's observations without noise, no curricula, and (unless `pushes`) no interval events."""
    from agile.rl_env.managers import EventTerm

    env_cfg.curriculum = None
    for agent_cfg in env_cfg.agents.values():
        inference_cfg(agent_cfg)
        for events in (agent_cfg.events, env_cfg.events):
            if events is None or pushes:
                continue
            for name, term in vars(events).items():
                if isinstance(term, EventTerm) and term.mode == "interval":
                    setattr(events, name, None)
    return env_cfg


def episode_slots(world, num_episodes: int) -> int:
    return num_episodes * world.max_episode_physics_steps // world.schedule.hyperperiod_steps * \
        len(world.schedule.slots)


def acting_actions(world, policies: dict) -> dict:
    """{agent: actions} of the agents acting at the world's next step, from their groups' policies
    (`policies[view]`: a group's observations to its actions)."""
    acting = set(world.acting_agents)
    actions = {}
    for view, act in policies.items():
        if view.agent_names[0] in acting:
            actions.update(view.split_actions(act(view.get_observations())))
    return actions


def evaluate(world, policies: dict, num_slots: int, recorders=(), command_name: str = "base_velocity") -> dict:
    """Per agent: falls (its termination fired) and which failure term ended them (`falls_by_term`: an episode two
    terms ended counts for both, as in single-agent evaluation), velocity tracking error while alive, reward terms,
    over `num_slots` steps of the world from a reset. `policies[view]` maps a group's observations to its actions."""
    import torch

    world.reset()
    stats = {name: {"falls": torch.zeros((), device=world.device), "lin": torch.zeros((), device=world.device),
                    "ang": torch.zeros((), device=world.device), "alive_steps": torch.zeros((), device=world.device),
                    "steps": 0, "terms": {t: torch.zeros((), device=world.device) for t in a.reward_manager.weights},
                    "ended_by": {t: torch.zeros((), device=world.device)
                                 for t, cfg in a.termination_manager.term_cfgs.items() if not cfg.time_out}}
             for name, a in world.agents.items()}
    commands = {}  # each agent's command over its current period
    with torch.inference_mode():
        for _ in range(num_slots):
            acting = set(world.acting_agents)
            commands.update({n: world.agents[n].command_manager.get_command(command_name).clone() for n in acting})
            steps = world.step(acting_actions(world, policies))
            for recorder in recorders:
                recorder.record(world)
            for name, step in steps.items():
                agent, s = world.agents[name], stats[name]
                robot = agent.scene["robot"]
                playing = step.alive & ~(step.terminated | step.truncated)  # a reset env shows its next episode
                command = commands[name]
                s["lin"] += (torch.linalg.norm(command[:, :2] - robot.root_lin_vel_b[:, :2], dim=1) * playing).sum()
                s["ang"] += ((command[:, 2] - robot.root_ang_vel_b[:, 2]).abs() * playing).sum()
                s["alive_steps"] += playing.sum()
                fell = step.terminated & step.alive
                s["falls"] += fell.sum()
                for t in s["ended_by"]:  # the terms' values of this agent's step, kept through its resets
                    s["ended_by"][t] += (agent.termination_manager.term_dones[t] & fell).sum()
                s["steps"] += 1
                for t in s["terms"]:
                    s["terms"][t] += (agent.reward_manager.step_reward[t] * step.alive).sum()
    result = {}
    for name, s in stats.items():
        alive_steps = max(float(s["alive_steps"]), 1.0)
        result[name] = {
            "control_hz": round(1.0 / world.agents[name].step_dt, 3), "falls": int(s["falls"]),
            "falls_by_term": {t: int(v) for t, v in s["ended_by"].items()},
            "lin_vel_error_mps": float(s["lin"]) / alive_steps, "ang_vel_error_radps": float(s["ang"]) / alive_steps,
            "reward_per_step": {t: float(v) / (world.num_envs * s["steps"]) for t, v in s["terms"].items()}}
    return result
