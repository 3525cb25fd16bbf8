"""Data-parallel training over the processes `torchrun` starts: every rank steps its own envs on its own device
(cuda:LOCAL_RANK, or the CPU), rsl-rl all-reduces the gradients and broadcasts rank 0's weights at the start, and
only rank 0 writes logs, checkpoints, exports and videos (rsl-rl's logger is silent on the other ranks)."""

from __future__ import annotations

import dataclasses
import hashlib
import os

import torch


@dataclasses.dataclass(frozen=True)
class Rank:
    rank: int
    """Global rank (torchrun's RANK)."""
    local_rank: int
    """Rank on this host (LOCAL_RANK): the GPU index."""
    world_size: int

    @property
    def is_main(self) -> bool:
        return self.rank == 0


def rank_from_env() -> Rank | None:
    """This process's rank from torchrun's variables, or None when it runs alone (WORLD_SIZE unset or 1)."""
    world_size = int(os.getenv("WORLD_SIZE", "1"))
    if world_size <= 1:
        return None
    return Rank(rank=int(os.getenv("RANK", "0")), local_rank=int(os.getenv("LOCAL_RANK", "0")), world_size=world_size)


def rank_device(rank: Rank, requested: str | None) -> str:
    """cuda:LOCAL_RANK, or "cpu" when the CPU was asked for (gloo); another GPU index is an error."""
    if requested == "cpu":
        return "cpu"
    expected = f"cuda:{rank.local_rank}"
    if requested not in (None, "cuda", expected):
        raise ValueError(f"--device {requested}: with --distributed each rank runs on cuda:LOCAL_RANK "
                         f"(rank {rank.rank} on {expected}); leave --device out, or pass --device cpu")
    return expected


def make_current(device: str) -> None:
    """Make a rank's GPU the process's current device for torch and Warp before anything is built: an allocation
    or launch that names no device (in Newton, MuJoCo Warp, torch's defaults) then lands on this rank's GPU,
    not on cuda:0 beside rank 0's envs. Nothing to do on the CPU."""
    if not device.startswith("cuda"):
        return
    import warp as wp

    torch.cuda.set_device(device)
    wp.set_device(device)


def init_cpu_process_group(rank: Rank) -> None:
    """rsl-rl sets up NCCL for CUDA ranks itself; CPU ranks (tests, CPU clusters) use gloo."""
    torch.distributed.init_process_group(backend="gloo", rank=rank.rank, world_size=rank.world_size)


def weights_digest(saved: dict) -> str:
    """sha256 over every model tensor of an algorithm's `save()` (optimizer state excluded), in key order."""
    digest = hashlib.sha256()
    for name in sorted(k for k in saved if k.endswith("_state_dict") and not k.startswith("optimizer")):
        for key, tensor in sorted(saved[name].items()):
            digest.update(key.encode())
            digest.update(tensor.detach().to("cpu").contiguous().numpy().tobytes())
    return digest.hexdigest()


def gather_digests(digest: str) -> list[str]:
    """Every rank's digest, in rank order (a collective: every rank calls it)."""
    digests: list[str | None] = [None] * torch.distributed.get_world_size()
    torch.distributed.all_gather_object(digests, digest)
    return [str(d) for d in digests]
