"""CaptureGuard: on the CPU, what a CUDA graph capture of the env step would refuse raises, naming the line."""

import dataclasses

import gymnasium as gym
import pytest
import torch

import agile.tasks
from agile.rl_env.capture_guard import CaptureGuard, CaptureSafetyError


@pytest.mark.parametrize("refused", [
    lambda x, mask: torch.tensor([1.0, 2.0]),
    lambda x, mask: torch.as_tensor([0.0, 0.0, -1.0]),
    lambda x, mask: torch.from_numpy(x.numpy()),
    lambda x, mask: x.sum().item(),
    lambda x, mask: x.tolist(),
    lambda x, mask: bool(mask.any()),
    lambda x, mask: float(x[0]),
    lambda x, mask: x[mask],
    lambda x, mask: x.__setitem__(mask, 0.0),
    lambda x, mask: torch.nonzero(mask),
    lambda x, mask: mask.nonzero(),
    lambda x, mask: torch.where(mask),
    lambda x, mask: x.masked_select(mask),
    lambda x, mask: torch.unique(x),
])
def test_refused_operations_raise_naming_the_line(refused):
    x, mask = torch.arange(4.0), torch.tensor([True, False, True, False])
    with pytest.raises(CaptureSafetyError, match=r"test_capture_guard\.py:\d+"), CaptureGuard():
        refused(x, mask)


def test_device_side_math_passes():
    x, mask = torch.arange(4.0), torch.tensor([True, False, True, False])
    with CaptureGuard():
        down = torch.zeros_like(x[:3])
        down[2] = -1.0
        y = torch.where(mask, x, torch.zeros_like(x))
        y = y.masked_fill(~mask, 2.0) + torch.as_tensor(x, dtype=torch.float64).float()  # a cast of a tensor
        z = x[1:3] * torch.full((2,), 0.5) + x[torch.arange(2)]  # slices and integer indices keep their shape
    assert down.tolist() == [0.0, 0.0, -1.0] and y.tolist() == [0.0, 3.0, 4.0, 5.0] and z.tolist() == [0.5, 2.0]


def _reward_from_host_data(env, **params):
    return torch.tensor([1.0] * env.num_envs)  # on the GPU: a host-to-device copy inside the captured step


@pytest.mark.parametrize("check", [True, False])
def test_env_step_with_a_host_data_term_raises_after_the_warm_up(check):
    env_cfg, _ = agile.tasks.load_cfgs("Velocity-T1-v0")
    env_cfg.check_capture_safety = check
    env_cfg.scene.terrain, env_cfg.curriculum.terrain_levels = None, None  # the terrain plays no part here
    name = dataclasses.fields(env_cfg.rewards)[0].name
    getattr(env_cfg.rewards, name).func = _reward_from_host_data
    env = gym.make("Velocity-T1-v0", cfg=env_cfg, num_envs=2, device="cpu").unwrapped
    env.reset()
    action = torch.zeros(2, env.action_manager.total_action_dim)
    for _ in range(3):  # the capture's warm-up runs eagerly on the GPU too: not checked
        env.step(action)
    if check:
        with pytest.raises(CaptureSafetyError, match=r"torch\.tensor at .*test_capture_guard\.py:\d+ "
                                                     r"\(_reward_from_host_data\) makes a tensor from host data"):
            env.step(action)
    else:
        env.step(action)
    env.close()
