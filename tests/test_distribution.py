"""SyncFreeGaussianDistribution draws what rsl-rl's GaussianDistribution draws, from the same generator state, without
the host synchronisation of `torch.normal`'s std check (GPU test); the registered policies use it."""

from __future__ import annotations

import pytest
import torch
from rsl_rl.models import MLPModel
from rsl_rl.modules.distribution import GaussianDistribution
from rsl_rl.utils import resolve_callable
from tensordict import TensorDict

import agile.tasks
from agile.rl import to_rsl_rl_dict
from agile.rl.distribution import SyncFreeGaussianDistribution

NUM_ENVS, NUM_ACTIONS = 64, 12


def both(std_type: str, device: str = "cpu"):
    """rsl-rl's distribution and ours with the same parameters, updated with the same means."""
    ours = SyncFreeGaussianDistribution(NUM_ACTIONS, init_std=0.7, std_type=std_type).to(device)
    theirs = GaussianDistribution(NUM_ACTIONS, init_std=0.7, std_type=std_type).to(device)
    theirs.load_state_dict(ours.state_dict())
    mean = torch.randn(NUM_ENVS, NUM_ACTIONS, device=device)
    ours.update(mean)
    theirs.update(mean)
    return ours, theirs


@pytest.mark.parametrize("std_type", ["scalar", "log"])
def test_same_draws_as_rsl_rl(std_type):
    ours, theirs = both(std_type)
    with torch.no_grad():  # the std parameter differs per action: the draws must scale per column
        for distribution in (ours, theirs):
            param = distribution.std_param if std_type == "scalar" else distribution.log_std_param
            param.copy_(torch.linspace(-1.0, 0.5, NUM_ACTIONS).exp() if std_type == "scalar"
                        else torch.linspace(-1.0, 0.5, NUM_ACTIONS))
    mean = torch.randn(NUM_ENVS, NUM_ACTIONS)
    ours.update(mean)
    theirs.update(mean)
    torch.manual_seed(3)
    expected, expected_next = theirs.sample(), torch.rand(3)
    torch.manual_seed(3)
    drawn, drawn_next = ours.sample(), torch.rand(3)
    assert drawn.shape == (NUM_ENVS, NUM_ACTIONS) and not drawn.requires_grad
    assert torch.equal(drawn, expected)
    assert torch.equal(drawn_next, expected_next)  # the generator moved on by the same draws
    assert torch.equal(ours.log_prob(drawn), theirs.log_prob(drawn))


def test_registered_policies_sample_without_synchronisation():
    _, agent_cfg = agile.tasks.load_cfgs("Velocity-G1-History-v0")
    distribution_cfg = to_rsl_rl_dict(agent_cfg)["actor"]["distribution_cfg"]
    assert resolve_callable(distribution_cfg["class_name"]) is SyncFreeGaussianDistribution


def test_shipped_checkpoint_weights_load():
    """The subclass adds no parameter: an actor saved with rsl-rl's distribution loads into ours and back."""
    def actor(class_name):
        obs = TensorDict({"policy": torch.zeros(2, 5)}, batch_size=[2])
        return MLPModel(obs, {"actor": ["policy"]}, "actor", NUM_ACTIONS,
                        hidden_dims=[8], distribution_cfg={"class_name": class_name, "init_std": 0.5})
    theirs = actor("GaussianDistribution")
    ours = actor("agile.rl.distribution:SyncFreeGaussianDistribution")
    ours.load_state_dict(theirs.state_dict())
    assert set(ours.state_dict()) == set(theirs.state_dict())


@pytest.mark.gpu
def test_no_host_synchronisation_on_gpu():
    if not torch.cuda.is_available():
        pytest.skip("needs a CUDA device")
    ours, theirs = both("scalar", device="cuda")
    torch.cuda.synchronize()
    torch.cuda.set_sync_debug_mode("error")
    try:
        with pytest.raises(RuntimeError, match="synchroniz"):  # rsl-rl's: the std check reads back
            theirs.sample()
        ours.sample()  # raises if it synchronises
    finally:
        torch.cuda.set_sync_debug_mode("default")
