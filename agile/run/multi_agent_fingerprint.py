"""The rollout of a multi-agent task's shipped policy for its fingerprint (agile/run/fingerprint.py): the world stepped
slot by slot on the CPU with its shipped agent groups acting, as an evaluation runs it (no observation noise, no
curriculum), pushes on.

A world step's row holds, for each agent acting at it, its actions (`actions/<agent>`), and for each agent whose
period ended there, its reward (`reward_total/<agent>`), weighted reward terms (`reward/<agent>/<term>`), termination
terms (`termination/<agent>/<term>`) and observation summaries (`obs/<agent>/<group>/<term>`); an agent with no such
result at a step has NaN there. The physics results (`state/`, `input/`) are one row per physics tick of the world, as
the replay writes the recorded state back after each tick."""

from __future__ import annotations

import numpy as np

from agile.run.fingerprint_rows import PhysicsSteps, observation_summary, stack_steps


def rollout(policy, env_cfg, agent_cfg, *, seed: int, num_steps: int,
            recording: dict[str, np.ndarray] | None) -> dict[str, np.ndarray]:
    """{name: array} of the rollout of `policy` (a fingerprint.ShippedPolicy) from a reset with `seed`, `num_steps`
    world steps; with `recording`, each tick's physics result replaced by the recorded one."""
    import torch

    from agile.run.multi_agent import restored_runner
    from agile.run.multi_agent_world import acting_actions, evaluation_cfg, make_world

    world = make_world(policy.task, evaluation_cfg(env_cfg, pushes=True), "cpu")
    try:
        runner, _ = restored_runner(world, agent_cfg, str(policy.file), trust=False)
        policies = {view: runner.runners[group].get_inference_policy(device="cpu")
                    for group, view in runner.views.items()}
        physics = PhysicsSteps(world.sim, recording)
        obs, _ = world.reset(seed=seed)
        steps = [{key: value for name, agent in world.agents.items()
                  for key, value in agent_summary(name, obs[name], agent).items()}]
        with world.sim.after_each_step(physics), torch.inference_mode():
            for _ in range(num_steps):
                actions = acting_actions(world, policies)
                results = world.step(actions)
                # copies: the world and its managers keep one buffer per quantity that the next step overwrites
                row = {f"actions/{name}": action.clone() for name, action in actions.items()}
                for name, result in results.items():
                    agent = world.agents[name]
                    # the total after its terms (STEP_KINDS): a term names a change better
                    row[f"reward_total/{name}"] = result.reward.clone()
                    row.update({f"reward/{name}/{t}": v.clone() for t, v in agent.reward_manager.step_reward.items()})
                    row.update({f"termination/{name}/{t}": v.float()
                                for t, v in agent.termination_manager.term_dones.items()})
                    row.update(agent_summary(name, result.obs, agent))
                steps.append(row)
    finally:
        world.close()
    ticks = [{}, *physics.rows]  # tick 0: the state after the reset, not recorded (NaN)
    return {**stack_steps(steps), **stack_steps(ticks)}


def agent_summary(name: str, obs, agent) -> dict:
    """One agent's observation summaries (`fingerprint_rows.observation_summary`), named obs/<agent>/<group>/<term>."""
    return {f"obs/{name}/{key[len('obs/'):]}": value
            for key, value in observation_summary(obs, agent.observation_manager.term_dims).items()}
