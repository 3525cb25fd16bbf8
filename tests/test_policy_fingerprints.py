"""A shipped policy never gets worse silently: each shipped policy file replays on the CPU as its committed recording
says (agile/run/fingerprint.py), on any x86-64 CPU. A change that moves one must re-record it in the same commit, with
a GPU eval showing the policy still passes (agile eval_all), and say so in the commit message."""

import os
import subprocess
import sys

import numpy as np
import pytest

from agile.run import fingerprint
from agile.run.fingerprint import (FINGERPRINT_DIR, check, first_divergence, load, mismatch_report, replay,
                                   shipped_policies)

POLICIES = shipped_policies()
T1 = next(p for p in POLICIES if p.file.name == "Velocity-T1-v0.pt")

INJECTED_STEPS = 10
"""The checks below inject a change and look for the step it shows at (0 to 2): the first steps of the replay do."""


@pytest.fixture(scope="module")
def t1_recording():
    return load(T1.fingerprint_file)


def injected(recording, *overrides: str) -> dict:
    """The T1 replay's first `INJECTED_STEPS` steps with `overrides` applied after the policy's own."""
    return replay(T1, recording, num_steps=INJECTED_STEPS, extra_overrides=overrides)


@pytest.mark.parametrize("policy", POLICIES, ids=[p.file.name for p in POLICIES])
def test_a_shipped_policy_replays_as_its_fingerprint_says(policy):
    report = check(policy)
    assert report is None, report


def test_every_shipped_policy_has_one_fingerprint_and_every_fingerprint_a_policy():
    files = sorted(str(f.relative_to(FINGERPRINT_DIR)) for f in FINGERPRINT_DIR.rglob("*.npz"))
    assert files == sorted(f"{p.file.stem}.npz" for p in POLICIES), "one <policy>.npz per shipped policy, no folders"


def test_the_replay_computes_from_the_recorded_states(t1_recording):
    """The terms and observations of a replayed step come from the recorded state, not the one the step computed: a
    recording whose first joint is 0.05 rad further after step 4's physics parts from the replay there, at an
    observation (the joint positions)."""
    moved = {name: values.copy() for name, values in t1_recording.items()}
    moved["state/joint_q"][4, :, 7] += 0.05  # the first joint after the free joint's 7 coordinates
    divergence = first_divergence(moved, replay(T1, moved, num_steps=6))
    assert divergence is not None and divergence.startswith("step 4: obs/"), divergence


def test_the_check_fails_on_the_action_clamp_that_made_the_t1_regression(t1_recording):
    """The regression of 1e8df33: the last-action observation clamped where the policy was trained without it
    (injected as a narrower clip_actions, 0.5, inside the T1 policy's outputs)."""
    divergence = first_divergence(t1_recording, injected(t1_recording, "env.clip_actions=0.5"))
    assert divergence is not None and divergence.startswith("step ")
    assert divergence.split(": ")[1].startswith(("obs/critic/actions", "obs/policy/actions")), divergence


def test_the_check_names_a_reweighted_reward_term(t1_recording):
    divergence = first_divergence(t1_recording, injected(t1_recording, "env.rewards.track_lin_vel_xy_exp.weight=0.5"))
    assert divergence is not None and divergence.startswith("step 1: reward/track_lin_vel_xy_exp"), divergence


def test_the_check_names_a_rescaled_observation(t1_recording):
    divergence = first_divergence(t1_recording, injected(t1_recording, "env.observations.policy.base_ang_vel.scale=0.3"))
    assert divergence is not None and divergence.startswith("step 0: obs/policy/base_ang_vel"), divergence


def test_the_check_names_changed_physics(t1_recording):
    """The physics step's own result is compared with the recorded state: gravity 20% weaker moves every env's
    joints in the first step beyond the tolerance (everything computed from the states still matches)."""
    divergence = first_divergence(t1_recording, injected(t1_recording, "env.sim.gravity_mps2=-7.85"))
    assert divergence is not None and divergence.startswith("step 1: state/joint_q"), divergence


MULTI_AGENT_TASK = "Shared-Go1-Velocity-v0"


@pytest.fixture(scope="module")
def multi_agent_policy(tmp_path_factory):
    """A multi-agent task's policy folder as agile ships one (<task>/<group>/model_<it>.pt), its group at its initial
    weights: what the fingerprint of a multi-agent policy records does not depend on training."""
    import agile.tasks
    from agile.marl.runner import MultiAgentRunner
    from agile.run.multi_agent_world import evaluation_cfg, make_world

    folder = tmp_path_factory.mktemp("policy") / MULTI_AGENT_TASK
    env_cfg, agent_cfg = agile.tasks.load_cfgs(MULTI_AGENT_TASK)
    env_cfg.num_envs = 2
    world = make_world(MULTI_AGENT_TASK, evaluation_cfg(env_cfg, pushes=True), "cpu")
    runner = MultiAgentRunner(world, agent_cfg, None, "cpu")
    for group, group_runner in runner.runners.items():
        (folder / group).mkdir(parents=True)
        group_runner.save(str(folder / group / "model_0.pt"))
    world.close()
    return fingerprint.ShippedPolicy(file=folder, task=MULTI_AGENT_TASK, overrides=())


def test_a_multi_agent_replay_names_the_agent_and_term_that_moved(multi_agent_policy):
    """A multi-agent policy is fingerprinted per agent: its replay matches its recording, and one agent's reward term
    reweighted is named with its agent at the first step while the other agents' quantities (and the world's state)
    still match."""
    recording = fingerprint.record(multi_agent_policy, num_steps=6)
    assert first_divergence(recording, replay(multi_agent_policy, recording)) is None
    agents = sorted(name[len("actions/"):] for name in recording if name.startswith("actions/"))
    assert agents == ["go1_a", "go1_b"] and recording["actions/go1_a"].shape == (7, fingerprint.NUM_ENVS, 12)
    reweighted = replay(multi_agent_policy, recording, num_steps=3,
                        extra_overrides=("env.agents.go1_a.rewards.track_lin_vel_xy_exp.weight=0.5",))
    divergence = first_divergence(recording, reweighted)
    assert divergence is not None and divergence.startswith("step 1: reward/go1_a/track_lin_vel_xy_exp"), divergence

    def others(quantities):  # every quantity not of go1_a
        return {name: values for name, values in quantities.items() if "/go1_a" not in name}

    assert first_divergence(others(recording), others(reweighted)) is None


@pytest.mark.slow
def test_the_replay_holds_when_torch_rounds_as_another_cpu_would():
    """The check is portable: with torch's kernels at another instruction-set level and MKL's reproducible mode
    (read when torch loads, so in a fresh process), each step's matrix products and term math round differently, as
    on another CPU model; the replay still matches within the tolerance."""
    env = {**os.environ, "ATEN_CPU_CAPABILITY": "default", "MKL_CBWR": "COMPATIBLE"}
    code = ("import sys; from agile.run.fingerprint import check, shipped_policies; "
            "report = check(next(p for p in shipped_policies() if p.file.name == 'Velocity-T1-v0.pt')); "
            "print(report or 'replays as recorded'); sys.exit(report is not None)")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]


def test_first_divergence_names_the_first_step_and_quantity_beyond_its_tolerance():
    """Hand values: the state has its own (absolute) tolerances, the other quantities atol + rtol |recorded|; NaN
    (step 0 of a per-step quantity) matches NaN; entries that are not compared (the replay's inputs) never part."""
    nan = np.full((1, 2), np.nan)
    recorded = {"actions": np.concatenate([nan, np.ones((2, 2))]), "state/joint_qd": np.zeros((3, 2, 1)),
                "input/contact/feet/net_forces_w_history": np.zeros((3, 2, 1)), "meta/seed": np.array(0)}
    recorded["state/joint_qd"][0] = np.nan
    same = {k: v.copy() for k, v in recorded.items()}
    same["actions"][1, 0] += 0.9e-3  # within 1e-4 + 1e-3 * 1
    same["state/joint_qd"][2, 1] += 0.9 * fingerprint.STATE_ATOL["state/joint_qd"]
    same["input/contact/feet/net_forces_w_history"] += 50.0
    assert first_divergence(recorded, same) is None
    moved = {k: v.copy() for k, v in same.items()}
    moved["state/joint_qd"][2, 1] += 0.2 * fingerprint.STATE_ATOL["state/joint_qd"]
    assert first_divergence(recorded, moved).startswith("step 2: state/joint_qd (env 1, entry (0,))")
    moved["actions"][2, 0] += 1.0
    assert first_divergence(recorded, moved).startswith("step 2: actions (env 0)")  # actions come before the state
    gone = {k: v for k, v in recorded.items() if k != "state/joint_qd"}
    assert "gone ['state/joint_qd']" in first_divergence(recorded, gone)


def test_a_report_says_where_it_was_recorded_and_how_to_re_record(t1_recording):
    report = mismatch_report(T1, t1_recording, "step 2: actions (env 0) is 1, recorded 0")
    assert f"recorded on {t1_recording['meta/cpu']}" in report and "step 2: actions" in report
    assert "agile fingerprint --record Velocity-T1-v0.pt" in report and "agile eval_all" in report


def test_record_writes_the_policys_fingerprint(tmp_path, monkeypatch, t1_recording):
    """The command's file handling (the recorder replaced by the T1 recording): --record writes <policy>.npz, --check
    replays it; a policy without a recording is told how to make one."""
    monkeypatch.setattr(fingerprint, "FINGERPRINT_DIR", tmp_path)
    assert check(T1).startswith("Velocity-T1-v0.pt has no fingerprint: agile fingerprint --record")
    monkeypatch.setattr(fingerprint, "record", lambda policy: t1_recording)
    assert fingerprint.main(["--record", T1.file.name]) == 0
    written = load(tmp_path / "Velocity-T1-v0.npz")
    np.testing.assert_array_equal(written["actions"], t1_recording["actions"])
    assert str(written["meta/cpu"]) == str(t1_recording["meta/cpu"])
