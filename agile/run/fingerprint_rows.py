"""What a fingerprint's rows are made of, for the rollout of a single-agent task (agile/run/fingerprint.py) and of a
multi-agent world (agile/run/multi_agent_fingerprint.py): each physics step's result, the observation summaries, and
the stacking of per-step rows into arrays."""

from __future__ import annotations

import numpy as np

INPUT_PREFIX = "input/"
"""A physics result's entries that are inputs of the replay, not compared (each step's actuator torques and contact
readings)."""


class PhysicsSteps:
    """The hook run after each physics step (`Simulation.after_each_step`): keeps the step's result as a fingerprint row
    (`rows`, one per step from the first); in a replay it then writes the recorded state of that step in its place,
    before anything reads it."""

    def __init__(self, sim, recording: dict[str, np.ndarray] | None):
        self.sim, self.recording = sim, recording
        self.rows: list[dict] = []

    def __call__(self) -> None:
        import torch

        result = self.sim.physics_result()
        self.rows.append({_physics_key(name): value for name, value in result.items()})
        if self.recording is not None:
            step = len(self.rows)
            self.sim.write_physics_result({name: torch.from_numpy(self.recording[_physics_key(name)][step])
                                           for name in result})


def stack_steps(steps: list[dict]) -> dict[str, np.ndarray]:
    """{name: (steps, ...) array} of per-step rows: NaN at a step without the quantity (step 0, the observations
    after the reset, has no other; a multi-agent step has the results of the agents whose period ended)."""
    like = {}
    for step in steps:
        for name, value in step.items():
            like.setdefault(name, value)
    return {name: np.stack([_as_array(s.get(name), like[name]) for s in steps]) for name in like}


def _physics_key(name: str) -> str:
    """A physics result's entry in the fingerprint: the joint state is compared ("state/"); the actuators' torques and
    the contact sensors' readings are inputs of the replay ("input/"): stiff contacts make them differ between CPUs by
    more than rounding (a lying G1's contact forces by ~10% after one step from the same state)."""
    return f"state/{name}" if name in ("joint_q", "joint_qd") else f"{INPUT_PREFIX}{name}"


def observation_summary(obs, term_dims: dict[str, dict[str, int]]) -> dict:
    """Per observation term, (N, 2): the mean and the root mean square over its entries (a concatenated group is
    split by the observation manager's `term_dims`)."""
    import torch
    from tensordict import TensorDict

    out = {}
    for group in obs.keys():
        value = obs[group]
        if isinstance(value, TensorDict):
            terms = {k: value[k] for k in value.keys()}
        else:
            terms = dict(zip(term_dims[group], torch.split(value, list(term_dims[group].values()), dim=-1)))
        for term, x in terms.items():
            x = x.reshape(x.shape[0], -1).double()
            out[f"obs/{group}/{term}"] = torch.stack((x.mean(dim=1), x.square().mean(dim=1).sqrt()), 1)
    return out


def _as_array(value, like) -> np.ndarray:
    if value is None:
        return np.full(tuple(like.shape), np.nan)
    return value.detach().double().cpu().numpy()
