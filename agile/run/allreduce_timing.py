"""The all-reduce of a training update's gradients, timed alone: every rank that `torchrun` starts sums a float32
tensor of the given size over the ranks (NCCL on cuda:LOCAL_RANK, gloo on the CPU), as rsl-rl's PPO does once per
mini-batch, and rank 0 writes the median seconds of one to --out (JSON). `agile gpu_scaling` runs it after each
training of several GPUs.

    torchrun --standalone --nproc_per_node=4 -m agile.run.allreduce_timing --floats 358809 --out allreduce.json
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time

from agile.run import arguments
from agile.run.arguments import command


def time_allreduce(*, floats: int, repeats: int, device: str) -> list[float]:
    """Seconds of each of `repeats` all-reduces (sum) of `floats` float32 values in the process group, after five
    untimed ones; the device is synchronised around each, so a time is one collective from start to end."""
    import torch

    payload = torch.ones(floats, dtype=torch.float32, device=device)
    sync = torch.cuda.synchronize if device.startswith("cuda") else (lambda: None)
    times = []
    for i in range(5 + repeats):
        sync()
        start = time.perf_counter()
        torch.distributed.all_reduce(payload)
        sync()
        if i >= 5:
            times.append(time.perf_counter() - start)
    return times


@command
def main(argv=None) -> int:
    import torch

    from agile.errors import AgileError
    from agile.rl.distributed import make_current, rank_device, rank_from_env

    parser = arguments.new_parser(__doc__)
    parser.add_argument("--floats", type=int, required=True, help="float32 values all-reduced (the gradients)")
    parser.add_argument("--repeats", type=int, default=50, help="all-reduces timed")
    parser.add_argument("--device", default=None, help="cpu for CPU ranks (gloo); default cuda:LOCAL_RANK")
    parser.add_argument("--out", required=True, help="rank 0 writes the timings here (JSON)")
    args = arguments.parse(parser, argv)
    if args.floats < 1 or args.repeats < 1:
        raise AgileError(f"--floats and --repeats must be positive, got {args.floats} and {args.repeats}")
    rank = rank_from_env()
    if rank is None:
        raise AgileError("start it with torchrun over two or more processes (WORLD_SIZE is unset or 1)")
    try:
        device = rank_device(rank, args.device)
    except ValueError as err:
        raise AgileError(str(err)) from err
    make_current(device)
    torch.distributed.init_process_group(backend="nccl" if device.startswith("cuda") else "gloo",
                                         rank=rank.rank, world_size=rank.world_size)
    times = time_allreduce(floats=args.floats, repeats=args.repeats, device=device)
    torch.distributed.destroy_process_group()
    if rank.is_main:
        result = {"ranks": rank.world_size, "device": device, "floats": args.floats, "repeats": args.repeats,
                  "median_s": statistics.median(times), "min_s": min(times), "max_s": max(times),
                  "nccl_env": {k: v for k, v in os.environ.items() if k.startswith("NCCL_")}}
        with open(args.out, "w") as file:
            json.dump(result, file, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
