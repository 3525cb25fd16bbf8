"""rsl-rl's Gaussian action distribution, sampled without a host synchronisation.

rsl-rl's `GaussianDistribution.sample` calls `torch.distributions.Normal.sample`, that is `torch.normal(mean, std)`,
which on a GPU checks that every std is non-negative by reading the minimum back to the host: the host waits at
every env step of a rollout for the GPU to finish the step it queued before (the env step's whole graph), and the
GPU then idles while Python launches the policy's, the storage's and the next env step's work (measured on an H100,
`torch.cuda.set_sync_debug_mode`: 2 synchronisations per env step, the only ones of a rollout; docs/benchmarks.md).
`SyncFreeGaussianDistribution` draws the same numbers in the same way (`torch.normal` fills its output with standard
normal draws, then scales by std and adds the mean; here `randn_like` draws, the same generator, the same order) with
no check: std is clamped to `std_range`, whose lower bound rsl-rl keeps at 1e-6 or more, so it is never negative.
Everything else (parameters, log-probabilities, entropy, export) is rsl-rl's: checkpoints load either way.
"""

from __future__ import annotations

import torch
from rsl_rl.modules.distribution import GaussianDistribution

from agile.rl.rsl_rl_adapter import gaussian_mean_std


class SyncFreeGaussianDistribution(GaussianDistribution):
    def sample(self) -> torch.Tensor:
        mean, std = gaussian_mean_std(self)
        with torch.no_grad():
            return torch.randn_like(mean).mul_(std).add_(mean)
