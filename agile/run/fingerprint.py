"""Rollout fingerprints of the shipped policies: a shipped policy must never get worse without a test failing.

A fingerprint is what one shipped policy file does in its task, on the CPU, from a fixed seed: a few envs, a hundred
steps, the task as registered plus the policy's training conditions (`conditions.yaml`, the motion of a per-motion
policy), run for inference (no observation noise, no curriculum, no training-only aids). Per step it holds every
action, every reward term (weighted, before the step's dt), every termination term, each observation term's mean and
root mean square over its entries, per env, and the state the step's physics left: every joint's coordinates and
velocities, robots' and objects' (a free body has a free joint), from which all body poses follow. A task whose
resets draw from a fallen-state dataset also keeps that dataset.

The check replays the recording instead of rolling out again, so that it holds on any x86-64 CPU. A rollout is chaotic:
two CPU models round a physics step differently (another summation order, fused multiply-adds, AVX2 or AVX-512
kernels), and an unchanged policy's second rollout on another CPU parts from the first within a few steps (T1: 2.5e-6
rad/s after one step, 1.6e-3 two steps later, on an AMD EPYC against an AVX-512 CPU of another model). In the replay
each step runs as training runs it (the policy acts on the observations, the actions drive the actuators, physics
steps), then the recorded state of that step takes the place of the one just computed, before anything reads it: the
terms, resets and next observations are computed from the recorded states, so that a rounding difference never
compounds. Compared step by step: the observations, actions, reward and termination terms (to RTOL, ATOL), and the
physics step's own result against the recorded state (to STATE_ATOL: one step from the same state, which another CPU's
rounding moves by ~1e-6 and a changed gain, mass, gravity or solver setting by far more). The fallen-state dataset is
an input of the replay, not compared (its collection is a 2.5 s chaotic fall per state): the recorded one replaces the
one the env collected.

`first_divergence` names the first step, quantity and env that differ beyond the tolerance. A change that moves a
fingerprint is a change to what a shipped policy does: re-record it in the same commit, with a GPU eval showing that
the policy still passes its criteria (`agile eval_all`), and say so.

    agile fingerprint --check              # every shipped policy replayed against its recording
    agile fingerprint --record [FILE...]   # the rollout moved on purpose: record it anew
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import platform
import sys
from pathlib import Path

import numpy as np

from agile.run.fingerprint_rows import INPUT_PREFIX, PhysicsSteps, observation_summary, stack_steps

POLICY_DIR = Path(__file__).resolve().parents[1] / "data" / "policy"
"""agile.tasks.PRETRAINED_DIR, named here without importing torch."""
FINGERPRINT_DIR = POLICY_DIR / "fingerprints"
NUM_ENVS = 4
NUM_STEPS = 100
"""Two seconds at 50 Hz: a walking gait's contacts, pushes and the resets of the first falls."""
SEED = 0
RTOL, ATOL = 1e-3, 1e-4
"""Observations, actions, reward and termination terms: computed from the same (recorded) states, they differ between
CPUs by rounding only (~1e-6); a semantic change (an observation clamped, a reward term reweighted) moves them by 1e-2
or more."""
STATE_ATOL = {"state/joint_q": 1e-3, "state/joint_qd": 1e-2}
"""The physics step's result against the recorded state, joint coordinates [rad, m] and velocities [rad/s, m/s]:
one env step of physics from the same state (docs/policies.md, "Rollout fingerprints", has the residuals measured
under other rounding)."""
STATE_OUTLIER_FRACTION = 0.05
"""The share of env-steps whose physics result may lie beyond STATE_ATOL: a contact that makes or breaks within one
step under one rounding and not under another (an impact) moves that step's velocities by up to ~0.2 rad/s (measured
under other rounding: Velocity-G1-History, 2 of 400 env-steps beyond 0.01 rad/s; HeightTracking-G1, lying on the
ground, 5 of 400); a change of the physics moves every env-step."""
STEP_KINDS = ("obs/", "actions", "state/", "reward/", "termination/", "reward")
"""A step's quantities in the order a divergence is looked for (a reward term names a change better than the sum)."""
DATASET_PREFIX, META_PREFIX = "dataset/", "meta/"
"""Fingerprint entries that are not compared: the fallen-state dataset the resets drew from, the recording's CPU and
seed; also INPUT_PREFIX's (agile/run/fingerprint_rows.py), each step's actuator torques and contact readings."""


def this_cpu() -> str:
    """The CPU model, `<vendor>-family<F>-model<M>` from /proc/cpuinfo (`platform.machine()` and
    `platform.processor()` where there is none): where a recording was made, for the reports."""
    fields = {}
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as cpuinfo:
        for line in cpuinfo:
            key, _, value = line.partition(":")
            if not line.strip():
                break  # the first processor's block describes the model
            fields[key.strip()] = value.strip()
    if {"vendor_id", "cpu family", "model"} <= fields.keys():
        return f"{fields['vendor_id']}-family{fields['cpu family']}-model{fields['model']}"
    return "-".join(filter(None, (platform.machine(), platform.processor()))) or "unknown"


@dataclasses.dataclass(frozen=True)
class ShippedPolicy:
    file: Path
    task: str
    overrides: tuple[str, ...]
    """Config overrides that give the policy's env: its training conditions, the motion it was trained on."""

    @property
    def fingerprint_file(self) -> Path:
        return FINGERPRINT_DIR / f"{self.file.name if self.file.is_dir() else self.file.stem}.npz"


def shipped_policies() -> list[ShippedPolicy]:
    """Every policy agile ships (agile/data/policy/*.pt, and a multi-agent task's folder of group checkpoints), with the
    task and overrides it runs in."""
    import agile.tasks

    policies = []
    folders = [p for p in POLICY_DIR.iterdir() if p.is_dir() and any(p.glob(agile.tasks.MULTI_AGENT_CHECKPOINTS))]
    for file in sorted([*POLICY_DIR.glob("*.pt"), *folders]):
        task, _, variant = (file.name if file.is_dir() else file.stem).partition(".")
        overrides = [f"env.{o}" for o in agile.tasks.pretrained_policy_conditions(task)[1]]
        if variant:  # one policy per value of a config field (a motion): <task>.<value>.pt
            overrides.append(f"env.{agile.tasks.task_spec(task).shipped_policy_per}={variant}")
        policies.append(ShippedPolicy(file=file, task=task, overrides=tuple(overrides)))
    return policies


@contextlib.contextmanager
def one_torch_thread():
    """One intra-op thread: the same summation order whatever the machine's core count."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def record(policy: ShippedPolicy, *, num_envs: int = NUM_ENVS, num_steps: int = NUM_STEPS, seed: int = SEED,
           extra_overrides: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """The policy's fingerprint: its rollout on the CPU ({name: array}; a step quantity has the step as first axis,
    the observations after the reset being step 0). `extra_overrides` change the env after the policy's own."""
    return _rollout(policy, num_envs=num_envs, num_steps=num_steps, seed=seed, extra_overrides=extra_overrides)


def replay(policy: ShippedPolicy, recording: dict[str, np.ndarray], *, num_steps: int | None = None,
           extra_overrides: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """The policy run again with the recording's envs, seed and dataset, each step's physics result replaced by the
    recorded state (the first `num_steps` steps, default all). The result's `state/` rows hold this machine's own
    physics results, before the replacement: `first_divergence(recording, replay(...))` compares them."""
    # (steps + 1, envs, ...): the actions, or a multi-agent recording's first agent's
    actions = next(v for k, v in sorted(recording.items()) if k == "actions" or k.startswith("actions/"))
    recorded_steps = len(actions) - 1
    num_steps = recorded_steps if num_steps is None else num_steps
    if not 0 < num_steps <= recorded_steps:
        raise ValueError(f"num_steps must be in [1, {recorded_steps}] (the recording's steps), got {num_steps}")
    return _rollout(policy, num_envs=actions.shape[1], num_steps=num_steps, seed=int(recording[f"{META_PREFIX}seed"]),
                    extra_overrides=extra_overrides, recording=recording)


def _rollout(policy: ShippedPolicy, *, num_envs: int, num_steps: int, seed: int, extra_overrides: tuple[str, ...],
             recording: dict[str, np.ndarray] | None = None) -> dict[str, np.ndarray]:
    import torch

    import agile.tasks
    from agile.rl.checkpoints import load_checkpoint
    from agile.run.env import build_env
    from agile.run.policy import inference_cfg, load_policy
    from agile.utils.config import apply_overrides

    env_cfg, agent_cfg = agile.tasks.load_cfgs(policy.task)
    env_cfg.num_envs, env_cfg.seed, agent_cfg.seed = num_envs, seed, seed
    apply_overrides({"env": env_cfg, "agent": agent_cfg}, [*policy.overrides, *extra_overrides])
    if agile.tasks.task_kind(policy.task) == "multi_agent":
        from agile.run import multi_agent_fingerprint

        with one_torch_thread():
            fingerprint = multi_agent_fingerprint.rollout(policy, env_cfg, agent_cfg, seed=seed, num_steps=num_steps,
                                                          recording=recording)
        return {**fingerprint, f"{META_PREFIX}seed": np.array(seed), f"{META_PREFIX}cpu": np.array(this_cpu())}
    with one_torch_thread():
        # a fallen-state dataset is collected anew (a cached one may come from another seed); a replay swaps in the
        # recorded one before the rollout's first reset
        env = build_env(policy.task, inference_cfg(env_cfg), "cpu", use_cache=False)
        try:
            dataset_term = _fallen_state_term(env)
            if dataset_term is not None and recording is not None:
                dataset_term.set_dataset(_recorded_dataset(recording, env))
            act = load_policy(load_checkpoint(str(policy.file)), env, agent_cfg)
            physics = PhysicsSteps(env.sim, recording)
            obs, _ = env.reset(seed=seed)
            term_dims = env.observation_manager.term_dims
            steps = [observation_summary(obs, term_dims)]
            with env.sim.after_each_step(physics), torch.inference_mode():
                for _ in range(num_steps):
                    actions = act(obs)
                    obs, reward, _, _, _ = env.step(actions)
                    # copies: on the CPU the env returns, and its reward manager keeps, one buffer each that the
                    # next step overwrites (a row holding them would end with the last step's values in every step)
                    row = {"actions": actions.clone(), "reward": reward.clone(), **physics.rows[-1]}
                    row.update({f"reward/{n}": v.clone() for n, v in env.reward_manager.step_reward.items()})
                    row.update({f"termination/{n}": v.float()
                                for n, v in env.termination_manager.term_dones.items()})
                    steps.append({**row, **observation_summary(obs, term_dims)})
            dataset = {} if dataset_term is None else {f"{DATASET_PREFIX}{name}": value.cpu().numpy()
                                                       for name, value in dataset_term.states.tensors.items()}
        finally:
            env.close()
    return {**stack_steps(steps), **dataset, f"{META_PREFIX}seed": np.array(seed),
            f"{META_PREFIX}cpu": np.array(this_cpu())}


def _fallen_state_term(env):
    """The reset term that draws from a fallen-state dataset, or None."""
    from agile.tasks.stand_up.fallen_states import reset_from_fallen_dataset

    for name in env.event_manager.terms("reset"):
        term = env.event_manager.get_term(name)
        if isinstance(term, reset_from_fallen_dataset):
            return term
    return None


def _recorded_dataset(recording: dict[str, np.ndarray], env):
    import torch

    from agile.tasks.stand_up.fallen_states.dataset import STATE_FIELDS, FallenStates

    missing = [f for f in STATE_FIELDS if f"{DATASET_PREFIX}{f}" not in recording]
    if missing:
        raise ValueError(f"the recording holds no fallen-state dataset ({missing} missing): record it anew")
    tensors = {f: torch.from_numpy(recording[f"{DATASET_PREFIX}{f}"]).to(env.device) for f in STATE_FIELDS}
    return FallenStates(tensors, num_levels=env.sim.max_terrain_level)


def step_quantities(fingerprint: dict[str, np.ndarray]) -> list[str]:
    """The per-step entries of a fingerprint, in the order a divergence is looked for (STEP_KINDS)."""
    names = [n for n in fingerprint if not n.startswith((DATASET_PREFIX, META_PREFIX, INPUT_PREFIX))]
    return sorted(names, key=lambda n: (next(i for i, k in enumerate(STEP_KINDS) if n.startswith(k)), n))


def save(path: Path, fingerprint: dict[str, np.ndarray]) -> None:
    """Write `fingerprint` to `path`: step quantities as float32 (the state and the inputs are float32 already:
    a replay writes back exactly what the physics held), the dataset and metadata as they are; compressed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    steps = {*step_quantities(fingerprint), *(n for n in fingerprint if n.startswith(INPUT_PREFIX))}
    np.savez_compressed(path, **{k: v.astype(np.float32) if k in steps else v for k, v in fingerprint.items()})


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def first_divergence(expected: dict[str, np.ndarray], actual: dict[str, np.ndarray], rtol: float = RTOL,
                     atol: float = ATOL) -> str | None:
    """None when `actual`'s steps match `expected`'s within the tolerance (as many steps as `actual` holds); else
    where they first part: a quantity that only one of them has, or the first step (then the first quantity in
    STEP_KINDS order) and env beyond |actual - expected| <= atol + rtol |expected|; the state beyond STATE_ATOL, once
    more env-steps than STATE_OUTLIER_FRACTION allows are."""
    names, actual_names = step_quantities(expected), step_quantities(actual)
    only_expected, only_actual = sorted(set(names) - set(actual_names)), sorted(set(actual_names) - set(names))
    if only_expected or only_actual:
        return f"the rollout's quantities changed: gone {only_expected}, new {only_actual}"
    for name in names:
        if expected[name].shape[1:] != actual[name].shape[1:] or len(actual[name]) > len(expected[name]):
            return f"{name}: shape {actual[name].shape}, recorded {expected[name].shape}"
    partings = []  # (step, order, report) of each quantity that parts
    for order, name in enumerate(names):
        e, a = expected[name][:len(actual[name])], actual[name].astype(np.float32)
        bound = STATE_ATOL[name] if name in STATE_ATOL else atol + rtol * np.abs(e)
        bad = ~(np.abs(a - e) <= bound) & ~(np.isnan(a) & np.isnan(e))
        if name in STATE_ATOL:
            bad_env_steps = bad.reshape(*bad.shape[:2], -1).any(axis=2)
            allowed = int(STATE_OUTLIER_FRACTION * bad_env_steps[1:].size)
            if bad_env_steps.sum() <= allowed:
                continue
            beyond = f", {int(bad_env_steps.sum())} of {bad_env_steps[1:].size} env-steps beyond {STATE_ATOL[name]}"
        elif not bad.any():
            continue
        else:
            beyond = ""
        first = tuple(np.argwhere(bad)[0])
        step, env, *entry = first
        where = f"env {env}" + (f", entry {tuple(int(i) for i in entry)}" if entry else "")
        partings.append((step, order, f"step {step}: {name} ({where}) is {a[first]:.6g}, recorded {e[first]:.6g}"
                                      f"{beyond}"))
    return min(partings)[2] if partings else None


def mismatch_report(policy: ShippedPolicy, recording: dict[str, np.ndarray], divergence: str) -> str:
    """Why a replay does not match its recording, and what to do."""
    recorded_on = str(recording.get(f"{META_PREFIX}cpu", "an unnamed CPU"))
    return (f"{policy.file.name} no longer rolls out as recorded (recorded on {recorded_on}, replayed on "
            f"{this_cpu()}): {divergence}. If the change is meant, re-record it (agile fingerprint --record "
            f"{policy.file.name}) in the same commit, with a GPU eval (agile eval_all) showing that the policy still "
            f"passes its criteria, and say so in the commit message")


def check(policy: ShippedPolicy) -> str | None:
    """None when the policy replays as its recording says; else the report of where it does not (or that it has no
    recording)."""
    if not policy.fingerprint_file.exists():
        return f"{policy.file.name} has no fingerprint: agile fingerprint --record {policy.file.name}"
    recording = load(policy.fingerprint_file)
    divergence = first_divergence(recording, replay(policy, recording))
    return None if divergence is None else mismatch_report(policy, recording, divergence)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="replay every shipped policy against its recording")
    mode.add_argument("--record", action="store_true", help="the rollout moved on purpose: record it anew")
    parser.add_argument("files", nargs="*", help="policy files (names in agile/data/policy/); default: all")
    args = parser.parse_args(argv)
    policies = shipped_policies()
    if args.files:
        by_name = {p.file.name: p for p in policies}
        unknown = [f for f in args.files if Path(f).name not in by_name]
        if unknown:
            print(f"error: not shipped policies: {unknown}. Shipped: {sorted(by_name)}", file=sys.stderr)
            return 2
        policies = [by_name[Path(f).name] for f in args.files]
    failed = 0
    for policy in policies:
        if args.record:
            save(policy.fingerprint_file, record(policy))
            print(f"{policy.file.name}: recorded {policy.fingerprint_file}")
            continue
        report = check(policy)
        print(report or f"{policy.file.name}: replays as recorded")
        failed += report is not None
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
