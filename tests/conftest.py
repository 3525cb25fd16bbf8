"""Shared fixtures. Tests run on CPU with a few envs; Warp kernels compile once and stay cached."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
import torch
import warp as wp

wp.config.quiet = True
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))  # the one-off data generators


@pytest.fixture(scope="module", autouse=True)
def free_envs_after_each_module():
    """Envs and runners sit in reference cycles that hold the simulation's buffers until the garbage collector next
    runs: collect after every module, so that a worker running many does not grow until it is killed."""
    yield
    import gc

    gc.collect()


def pytest_collection_modifyitems(config, items):
    # the slow tests first (a stable sort: the same order on every xdist worker), so that the parallel run does not end
    # on one of them while the other workers idle
    items.sort(key=lambda item: "slow" not in item.keywords)
    if wp.is_cuda_available():
        return
    skip = pytest.mark.skip(reason="needs a CUDA device")
    for item in items:
        if "gpu" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def t1_env():
    import gymnasium as gym

    import agile.tasks  # noqa: F401

    env = gym.make("Velocity-T1-v0", num_envs=3, device="cpu", seed=0)
    yield env.unwrapped
    env.close()


@pytest.fixture(scope="session")
def height_tracking_env_and_agent(tmp_path_factory):
    """HeightTracking-G1-v0 on CPU (3 envs, 2 terrain rows, capture safety checked), its fallen-state dataset
    collected into a temporary cache, and its agent config: built once for test_height_tracking.py and
    test_height_command.py (the tests put back what they change)."""
    import contextlib
    import dataclasses
    import io

    import agile.tasks
    from agile.tasks.stand_up.fallen_states import FallenStateDatasetCfg
    from agile.run import task_setup

    env_cfg, agent_cfg = agile.tasks.load_cfgs("HeightTracking-G1-v0")
    env_cfg.num_envs = 3
    env_cfg.check_capture_safety = True  # every test's steps after the warm-up: nothing the GPU's graph refuses
    env_cfg.scene.terrain = dataclasses.replace(env_cfg.scene.terrain, num_rows=2, num_cols=3)
    env_cfg.events.reset_base.params["dataset"] = FallenStateDatasetCfg(
        cache_dir=str(tmp_path_factory.mktemp("fallen_cache")))
    with contextlib.redirect_stdout(io.StringIO()):
        env = task_setup.make_env(task="HeightTracking-G1-v0", env_cfg=env_cfg, device="cpu")  # collects the fallen-state dataset
    return env, agent_cfg


@pytest.fixture
def cpu():
    return torch.device("cpu")
