"""A shipped policy never gets worse silently: each shipped policy file rolls out on the CPU exactly as its committed
fingerprint says (agile/run/fingerprint.py). A change that moves one must re-record it in the same commit, with a
GPU eval showing the policy still passes (docs/eval_report/), and say so in the commit message."""

import pytest

from agile.run.fingerprint import (FINGERPRINT_DIR, first_divergence, load, record, require_pinned_numerics,
                                   shipped_policies)

POLICIES = shipped_policies()
T1 = next(p for p in POLICIES if p.file.name == "Velocity-T1-v0.pt")


INJECTED_STEPS = 10
"""The checks below inject a change and look for the step it shows at (0 to 2): the first steps of the rollout do."""


@pytest.fixture(scope="module")
def t1_fingerprint():
    """The T1 fingerprint's first `INJECTED_STEPS` steps (and the observations after the reset)."""
    return {name: values[:INJECTED_STEPS + 1] for name, values in load(T1.fingerprint_file).items()}


def injected(*overrides: str) -> dict:
    """The T1 rollout's first `INJECTED_STEPS` steps with `overrides` applied after the policy's own."""
    return record(T1, num_steps=INJECTED_STEPS, extra_overrides=overrides)


@pytest.mark.parametrize("policy", POLICIES, ids=[p.file.name for p in POLICIES])
def test_a_shipped_policy_rolls_out_as_its_fingerprint_says(policy):
    assert policy.fingerprint_file.is_file(), (
        f"{policy.file.name} has no fingerprint: python -m agile.run.fingerprint --record {policy.file.name}")
    divergence = first_divergence(load(policy.fingerprint_file), record(policy))
    assert divergence is None, (
        f"{policy.file.name} no longer rolls out as recorded: {divergence}. If the change is meant, re-record "
        f"(python -m agile.run.fingerprint --record {policy.file.name}) in the same commit, with a GPU eval "
        "(scripts/eval_all.py) showing that the policy still passes its criteria, and say so in the commit message")


def test_every_fingerprint_belongs_to_a_shipped_policy():
    shipped = {p.fingerprint_file.name for p in POLICIES}
    assert shipped  # the package ships policies
    stale = sorted(f.name for f in FINGERPRINT_DIR.glob("*.npz") if f.name not in shipped)
    assert not stale, f"fingerprints of policies no longer shipped: {stale}"


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
