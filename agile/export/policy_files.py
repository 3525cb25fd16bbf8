"""Policy export: TorchScript and ONNX files of a runner's acting model (observation normalisation folded in)."""

from __future__ import annotations

import os

import torch

from agile.rl.configs import policy_obs_set


def export_policy(runner, out_dir: str) -> tuple[str, str]:
    """policy.pt (TorchScript) and policy.onnx (weights inside the file) of an RSL-RL runner's actor.

    Both take the actor's observation groups concatenated, (batch, obs_dim), and return the mean action.
    A recurrent actor (rsl-rl's own export, batch 1) keeps its hidden state inside policy.pt, zeroed by its
    reset() method, while policy.onnx takes it as inputs and returns the next one as outputs (the descriptor's
    "policy" section names them).
    """
    import onnx

    os.makedirs(out_dir, exist_ok=True)
    runner.export_policy_to_jit(out_dir, filename="policy.pt")
    runner.export_policy_to_onnx(out_dir, filename="policy.onnx")
    onnx_path = os.path.join(out_dir, "policy.onnx")
    data_path = onnx_path + ".data"
    model = onnx.load(onnx_path)  # loads external weights too
    onnx.save(model, onnx_path, save_as_external_data=False)
    if os.path.exists(data_path):
        os.remove(data_path)
    return os.path.join(out_dir, "policy.pt"), onnx_path


def example_input(env, agent_cfg) -> torch.Tensor:
    from agile.rl.vecenv_wrapper import flatten_groups

    obs = flatten_groups(env.obs_buf)
    return torch.cat([obs[g] for g in agent_cfg.obs_groups[policy_obs_set(agent_cfg)]], dim=-1)
