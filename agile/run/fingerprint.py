"""Rollout fingerprints of the shipped policies: a shipped policy must never get worse without a test failing.

A fingerprint is what one shipped policy file does in its task, on the CPU, from a fixed seed: a few envs, a few
hundred steps, the task as registered plus the policy's training conditions (`conditions.yaml`, the motion of a
per-motion policy), run for inference (no observation noise, no curriculum, no training-only aids). Per step it
holds every action, every reward term (weighted, before the step's dt), every termination term, and for each
observation term its mean and root mean square over the term's entries, per env. `first_divergence` compares two
and names the first step, quantity and env that differ beyond the tolerance.

The rollouts are chaotic and two CPU models can round one physics step differently (see `this_cpu`), so a
policy keeps one recording per CPU model it was recorded on, `fingerprints/<cpu>/<policy>.npz`, and its rollout
must match one of them.

A change that moves a fingerprint is a change to what a shipped policy meets: re-record it in the same commit,
with a GPU eval showing that the policy still passes its criteria (`agile eval_all`), and say so.

    agile fingerprint --check              # every shipped policy against its recordings
    agile fingerprint --record [FILE...]   # rollout moved on purpose: this CPU's recording only
    agile fingerprint --add_cpu [FILE...]  # same code, a CPU model without a recording: add one
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import os
import platform
import sys
from pathlib import Path

import numpy as np

POLICY_DIR = Path(__file__).resolve().parents[1] / "data" / "policy"
"""agile.tasks.PRETRAINED_DIR, named here without importing torch (see PINNED_CPU_NUMERICS)."""
FINGERPRINT_DIR = POLICY_DIR / "fingerprints"
NUM_ENVS = 4
NUM_STEPS = 100
"""Two seconds at 50 Hz: long enough for a walking gait's contacts, pushes and resets of the first falls, short
enough that rounding differences between CPUs stay far inside the tolerance (see RTOL, ATOL)."""
SEED = 0
RTOL, ATOL = 1e-3, 1e-4
"""Measured on the CPU: a relative perturbation of 1e-6 on every action (rounding, another CPU's summation
order) moves no recorded value by more than about 1e-5 within NUM_STEPS steps (docs/policies.md, "Rollout
fingerprints"); a semantic change (an observation clamped, a reward term reweighted) moves them by 1e-2 or more."""


PINNED_CPU_NUMERICS = {"MKL_CBWR": "AVX2", "ATEN_CPU_CAPABILITY": "avx2"}
"""Environment variables that make torch compute alike across x86-64 CPUs with AVX2, read when torch loads: MKL's
AVX2 and AVX-512 kernels round differently (measured: the T1 fingerprint parts at step 1 between them), and a
physics step amplifies one rounding into a different solver result. tests/conftest.py and this module's main set
them before torch is imported."""


def this_cpu() -> str:
    """The CPU model as a folder name, `<vendor>-family<F>-model<M>` from /proc/cpuinfo (`platform.machine()` and
    `platform.processor()` where there is none).

    Why recordings are per CPU model: with the numerics pinned, an AMD EPYC (family 26, model 2) still parts from
    the recordings of the first CPU (an AVX-512 x86-64 CPU; its recordings, made before they named their CPU, are in
    `unnamed-avx512-cpu/`) at step 1: T1's step-1 actions are identical, the physics step's result differs by
    2.5e-6 rad/s in base angular velocity, 1.6e-3 two steps later; the same commit, the same wheels. Not the cause,
    each measured on it: Warp's CPU target, oneDNN's ISA, glibc's CPU-feature tunables, numpy's SIMD dispatch,
    ATen's capability, memory read uninitialised (docs/policies.md)."""
    fields = {}
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as cpuinfo:
        for line in cpuinfo:
            key, _, value = line.partition(":")
            if not line.strip():
                break  # the first processor's block describes the model
            fields[key.strip()] = value.strip()
    if {"vendor_id", "cpu family", "model"} <= fields.keys():
        return f"{fields['vendor_id']}-family{fields['cpu family']}-model{fields['model']}"
    name = "-".join(filter(None, (platform.machine(), platform.processor()))) or "unknown"
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


class UnpinnedNumericsError(RuntimeError):
    """Fingerprints recorded or checked without PINNED_CPU_NUMERICS would depend on the machine's CPU."""


def require_pinned_numerics() -> None:
    wrong = {k: os.environ.get(k) for k, v in PINNED_CPU_NUMERICS.items() if os.environ.get(k) != v}
    if wrong:
        settings = " ".join(f"{k}={v}" for k, v in PINNED_CPU_NUMERICS.items())
        raise UnpinnedNumericsError(f"fingerprints need {settings} in the environment before torch is imported "
                                    f"(now {wrong}); tests/conftest.py and `agile fingerprint` set them")


@dataclasses.dataclass(frozen=True)
class ShippedPolicy:
    file: Path
    task: str
    overrides: tuple[str, ...]
    """Config overrides that give the policy's env: its training conditions, the motion it was trained on."""

    def fingerprint_file(self, cpu: str) -> Path:
        """The policy's recording made on `cpu` (a `this_cpu()` name; the file may not exist)."""
        return FINGERPRINT_DIR / cpu / f"{self.file.stem}.npz"

    def recordings(self) -> dict[str, Path]:
        """{cpu: file} of every recording this policy has."""
        return {f.parent.name: f for f in sorted(FINGERPRINT_DIR.glob(f"*/{self.file.stem}.npz"))}


def shipped_policies() -> list[ShippedPolicy]:
    """Every policy file agile ships (agile/data/policy/*.pt), with the task and overrides it runs in."""
    import agile.tasks

    policies = []
    for file in sorted(POLICY_DIR.glob("*.pt")):
        task, _, variant = file.stem.partition(".")
        overrides = [f"env.{o}" for o in agile.tasks.pretrained_policy_conditions(task)[1]]
        if variant:  # one policy per value of a config field (a motion): <task>.<value>.pt
            overrides.append(f"env.{agile.tasks.task_spec(task).shipped_policy_per}={variant}")
        policies.append(ShippedPolicy(file=file, task=task, overrides=tuple(overrides)))
    return policies


@contextlib.contextmanager
def one_torch_thread():
    """One intra-op thread while recording: the same summation order whatever the machine's core count."""
    import torch

    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(threads)


def record(policy: ShippedPolicy, num_envs: int = NUM_ENVS, num_steps: int = NUM_STEPS, seed: int = SEED,
           extra_overrides: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """The policy's rollout fingerprint on the CPU ({name: array}, each with the step as first axis).
    `extra_overrides` change the env after the policy's own (what a test injects to show the check fails)."""
    require_pinned_numerics()
    import torch

    import agile.tasks
    from agile.rl.checkpoints import load_checkpoint
    from agile.run.env import build_env
    from agile.run.policy import inference_cfg, load_policy
    from agile.utils.config import apply_overrides

    env_cfg, agent_cfg = agile.tasks.load_cfgs(policy.task)
    env_cfg.num_envs, env_cfg.seed, agent_cfg.seed = num_envs, seed, seed
    apply_overrides({"env": env_cfg, "agent": agent_cfg}, [*policy.overrides, *extra_overrides])
    with one_torch_thread():
        # a fallen-state dataset is collected anew: a cached one may come from another seed
        env = build_env(policy.task, inference_cfg(env_cfg), "cpu", use_cache=False)
        try:
            act = load_policy(load_checkpoint(str(policy.file)), env, agent_cfg)
            obs, _ = env.reset(seed=seed)
            term_dims = env.observation_manager.term_dims
            steps = [_observation_summary(obs, term_dims)]
            with torch.inference_mode():
                for _ in range(num_steps):
                    actions = act(obs)
                    obs, reward, _, _, _ = env.step(actions)
                    # copies: on the CPU the env returns, and its reward manager keeps, one buffer each that the
                    # next step overwrites (a row holding them would end with the last step's values in every step)
                    row = {"actions": actions.clone(), "reward": reward.clone()}
                    row.update({f"reward/{n}": v.clone() for n, v in env.reward_manager.step_reward.items()})
                    row.update({f"termination/{n}": v.float()
                                for n, v in env.termination_manager.term_dones.items()})
                    steps.append({**row, **_observation_summary(obs, term_dims)})
        finally:
            env.close()
    # the observations after reset are step 0; every other quantity starts at step 1 (NaN at step 0)
    names = list(steps[1])
    return {name: np.stack([_as_array(s.get(name), steps[1][name]) for s in steps]) for name in names}


def _observation_summary(obs, term_dims: dict[str, dict[str, int]]) -> dict:
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


def save(path: Path, fingerprint: dict[str, np.ndarray]) -> None:
    """Write `fingerprint` (float32, compressed) to `path`, creating its CPU folder."""
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **{k: v.astype(np.float32) for k, v in fingerprint.items()})


def load(path: Path) -> dict[str, np.ndarray]:
    with np.load(path) as data:
        return {k: data[k] for k in data.files}


def check(policy: ShippedPolicy, actual: dict[str, np.ndarray]) -> tuple[str | None, dict[str, str]]:
    """(the CPU whose recording `actual` matches, or None; {cpu: first divergence} of those it does not match).
    This CPU's own recording is compared first."""
    recordings = policy.recordings()
    here = this_cpu()
    divergences = {}
    for cpu in sorted(recordings, key=lambda c: c != here):
        divergence = first_divergence(load(recordings[cpu]), actual)
        if divergence is None:
            return cpu, divergences
        divergences[cpu] = divergence
    return None, divergences


def mismatch_report(policy: ShippedPolicy, divergences: dict[str, str]) -> str:
    """Why a rollout matches none of its recordings, and what to do: a changed rollout when this CPU has a
    recording, else possibly only another CPU's rounding."""
    if not divergences:
        return f"{policy.file.name} has no fingerprint: agile fingerprint --record {policy.file.name}"
    here = this_cpu()
    parts = "; ".join(f"recorded on {cpu}: {d}" for cpu, d in divergences.items())
    fix = (f"If the change is meant, re-record (agile fingerprint --record {policy.file.name}) in "
           "the same commit, with a GPU eval (agile eval_all) showing that the policy still passes its criteria, "
           "and say so in the commit message")
    if here in divergences:
        return f"{policy.file.name} no longer rolls out as recorded on this CPU ({here}): {parts}. {fix}"
    return (f"{policy.file.name} matches none of its recordings, and none was made on this CPU ({here}): {parts}. "
            f"If this commit's parent rolls out the same here, only the CPU differs: add its recording "
            f"(agile fingerprint --add_cpu {policy.file.name}). {fix}")


def first_divergence(expected: dict[str, np.ndarray], actual: dict[str, np.ndarray], rtol: float = RTOL,
                     atol: float = ATOL) -> str | None:
    """None when `actual` matches `expected` within the tolerance; else where they first part: a quantity that
    only one of them has, or the first step (then the first quantity in order: observations, actions, reward
    terms, terminations) and env beyond |actual - expected| <= atol + rtol |expected|."""
    only_expected, only_actual = sorted(set(expected) - set(actual)), sorted(set(actual) - set(expected))
    if only_expected or only_actual:
        return f"the rollout's quantities changed: gone {only_expected}, new {only_actual}"
    for name in expected:
        if expected[name].shape != actual[name].shape:
            return f"{name}: shape {actual[name].shape}, recorded {expected[name].shape}"
    # observations, actions, reward terms, terminations, then the summed reward (a term names the change better)
    kinds = ("obs/", "actions", "reward/", "termination/", "reward")
    order = sorted(expected, key=lambda n: (next(i for i, k in enumerate(kinds) if n.startswith(k)), n))
    for step in range(len(expected["actions"])):
        for name in order:
            e, a = expected[name][step], actual[name][step].astype(np.float32)
            bad = ~(np.abs(a - e) <= atol + rtol * np.abs(e)) & ~(np.isnan(a) & np.isnan(e))
            if bad.any():
                first = tuple(np.argwhere(bad)[0])
                env, *entry = first
                where = f"env {env}" + (f", entry {tuple(int(i) for i in entry)}" if entry else "")
                return f"step {step}: {name} ({where}) is {a[first]:.6g}, recorded {e[first]:.6g}"
    return None


def main(argv=None) -> int:
    if "torch" not in sys.modules:
        os.environ.update(PINNED_CPU_NUMERICS)
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--check", action="store_true", help="compare every shipped policy with its recordings")
    mode.add_argument("--record", action="store_true",
                      help="the rollout moved on purpose: record it on this CPU and delete the other CPUs' recordings")
    mode.add_argument("--add_cpu", action="store_true",
                      help="the code's rollouts did not move: add this CPU's recording beside the others")
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
    here = this_cpu()
    failed = 0
    for policy in policies:
        fingerprint = record(policy)
        if args.record or args.add_cpu:
            stale = [f for cpu, f in policy.recordings().items() if cpu != here] if args.record else []
            for file in stale:
                file.unlink()
            save(policy.fingerprint_file(here), fingerprint)
            print(f"{policy.file.name}: recorded {policy.fingerprint_file(here)}"
                  + (f", deleted {len(stale)} other CPUs' recordings" if stale else ""))
            continue
        matched, divergences = check(policy, fingerprint)
        print(f"{policy.file.name}: unchanged (the recording of {matched})" if matched
              else mismatch_report(policy, divergences))
        failed += matched is None
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
