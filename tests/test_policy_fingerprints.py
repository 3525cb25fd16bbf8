"""A shipped policy never gets worse silently: each shipped policy file rolls out on the CPU exactly as one of its
committed recordings says (one per CPU model; agile/run/fingerprint.py). A change that moves one must re-record it
in the same commit, with a GPU eval showing the policy still passes (docs/eval_report/), and say so in the commit
message."""

import numpy as np
import pytest

from agile.run import fingerprint
from agile.run.fingerprint import (FINGERPRINT_DIR, check, first_divergence, load, mismatch_report, record,
                                   require_pinned_numerics, shipped_policies, this_cpu)

POLICIES = shipped_policies()
T1 = next(p for p in POLICIES if p.file.name == "Velocity-T1-v0.pt")


INJECTED_STEPS = 10
"""The checks below inject a change and look for the step it shows at (0 to 2): the first steps of the rollout do."""


@pytest.fixture(scope="module")
def t1_fingerprint():
    """The T1 fingerprint's first `INJECTED_STEPS` steps (and the observations after the reset), this CPU's recording
    where there is one: the CPUs' recordings part only from step 1 on, by about 1e-6."""
    recordings = T1.recordings()
    file = recordings.get(this_cpu(), next(iter(recordings.values())))
    return {name: values[:INJECTED_STEPS + 1] for name, values in load(file).items()}


def injected(*overrides: str) -> dict:
    """The T1 rollout's first `INJECTED_STEPS` steps with `overrides` applied after the policy's own."""
    return record(T1, num_steps=INJECTED_STEPS, extra_overrides=overrides)


@pytest.mark.parametrize("policy", POLICIES, ids=[p.file.name for p in POLICIES])
def test_a_shipped_policy_rolls_out_as_its_fingerprint_says(policy):
    matched, divergences = check(policy, record(policy))
    assert matched is not None, mismatch_report(policy, divergences)


def test_every_fingerprint_belongs_to_a_shipped_policy():
    shipped = {f"{p.file.stem}.npz" for p in POLICIES}
    assert shipped  # the package ships policies
    files = sorted(FINGERPRINT_DIR.rglob("*.npz"))
    stale = [str(f.relative_to(FINGERPRINT_DIR)) for f in files if f.name not in shipped]
    assert not stale, f"fingerprints of policies no longer shipped: {stale}"
    misplaced = [str(f.relative_to(FINGERPRINT_DIR)) for f in files if f.parent.parent != FINGERPRINT_DIR]
    assert not misplaced, f"recordings belong in fingerprints/<cpu>/: {misplaced}"


def test_this_cpu_names_a_folder():
    cpu = this_cpu()
    assert cpu and "/" not in cpu and not cpu.startswith(".")
    assert cpu == this_cpu()


def _fake_recordings(tmp_path, monkeypatch, recordings: dict[str, dict]):
    """T1's recordings replaced by `recordings` ({cpu: fingerprint}) under tmp_path."""
    monkeypatch.setattr(fingerprint, "FINGERPRINT_DIR", tmp_path)
    for cpu, values in recordings.items():
        fingerprint.save(T1.fingerprint_file(cpu), values)
    return T1


def _shifted(values: dict, step: int, by: float) -> dict:
    out = {k: v.copy() for k, v in values.items()}
    out["actions"][step] += by
    return out


def test_a_rollout_passes_when_any_cpus_recording_matches(tmp_path, monkeypatch, t1_fingerprint):
    other = _shifted(t1_fingerprint, 3, 0.5)
    policy = _fake_recordings(tmp_path, monkeypatch, {"OtherCPU-family1-model1": other,
                                                    "SomeCPU-family2-model2": t1_fingerprint})
    matched, divergences = check(policy, t1_fingerprint)
    assert matched == "SomeCPU-family2-model2"
    assert divergences["OtherCPU-family1-model1"].startswith("step 3: actions")


def test_a_moved_rollout_on_a_recorded_cpu_is_called_a_change(tmp_path, monkeypatch, t1_fingerprint):
    policy = _fake_recordings(tmp_path, monkeypatch, {this_cpu(): t1_fingerprint,
                                                    "OtherCPU-family1-model1": t1_fingerprint})
    moved = _shifted(t1_fingerprint, 2, 0.5)
    matched, divergences = check(policy, moved)
    assert matched is None and list(divergences)[0] == this_cpu()  # this CPU's own recording is compared first
    report = mismatch_report(policy, divergences)
    assert f"no longer rolls out as recorded on this CPU ({this_cpu()})" in report
    assert "step 2: actions" in report and "--record Velocity-T1-v0.pt" in report and "--add_cpu" not in report


def test_a_cpu_without_a_recording_is_told_how_to_add_one(tmp_path, monkeypatch, t1_fingerprint):
    policy = _fake_recordings(tmp_path, monkeypatch, {"OtherCPU-family1-model1": t1_fingerprint})
    matched, divergences = check(policy, _shifted(t1_fingerprint, 1, 1e-2))
    assert matched is None
    report = mismatch_report(policy, divergences)
    assert f"none was made on this CPU ({this_cpu()})" in report and "--add_cpu Velocity-T1-v0.pt" in report


def test_record_replaces_every_cpus_recording_and_add_cpu_keeps_them(tmp_path, monkeypatch, t1_fingerprint):
    """--record (the rollout moved on purpose) leaves only this CPU's recording; --add_cpu adds it beside the others.
    The recorder itself is replaced by the T1 fingerprint's first steps (the CLI's file handling is under test)."""
    policy = _fake_recordings(tmp_path, monkeypatch, {"OtherCPU-family1-model1": t1_fingerprint})
    monkeypatch.setattr(fingerprint, "record", lambda p: t1_fingerprint)
    assert fingerprint.main(["--add_cpu", T1.file.name]) == 0
    assert set(policy.recordings()) == {"OtherCPU-family1-model1", this_cpu()}
    assert fingerprint.main(["--check", T1.file.name]) == 0
    assert fingerprint.main(["--record", T1.file.name]) == 0
    assert set(policy.recordings()) == {this_cpu()}
    np.testing.assert_array_equal(load(policy.fingerprint_file(this_cpu()))["actions"], t1_fingerprint["actions"])


def test_the_check_fails_on_the_action_clamp_that_made_the_t1_regression(t1_fingerprint):
    """The regression of 1e8df33: the last-action observation clamped where the policy was trained without it
    (injected as a narrower clip_actions, 0.5, inside the T1 policy's outputs)."""
    divergence = first_divergence(t1_fingerprint, injected("env.clip_actions=0.5"))
    assert divergence is not None and divergence.startswith("step ")
    assert divergence.split(": ")[1].startswith(("obs/critic/actions", "obs/policy/actions")), divergence


def test_the_check_names_a_reweighted_reward_term(t1_fingerprint):
    divergence = first_divergence(t1_fingerprint, injected("env.rewards.track_lin_vel_xy_exp.weight=0.5"))
    assert divergence is not None and divergence.startswith("step 1: reward/track_lin_vel_xy_exp"), divergence


def test_the_check_names_a_rescaled_observation(t1_fingerprint):
    divergence = first_divergence(t1_fingerprint, injected("env.observations.policy.base_ang_vel.scale=0.3"))
    assert divergence is not None and divergence.startswith("step 0: obs/policy/base_ang_vel"), divergence


def test_fingerprints_refuse_unpinned_numerics(monkeypatch):
    monkeypatch.setenv("MKL_CBWR", "AUTO")
    with pytest.raises(RuntimeError, match="MKL_CBWR=AVX2"):
        require_pinned_numerics()
