"""Export a policy: TorchScript (policy.pt), ONNX (policy.onnx) and the IO descriptor (io_descriptor.yaml).

    agile export --task Velocity-G1-History-v0 --out exported/g1          # the shipped policy
    agile export --task Velocity-T1-v0 --checkpoint logs/.../model_3000.pt --out exported/t1

Both model files take the actor's observation groups concatenated, (batch, obs_dim), observation
normalisation included, and return the mean action. The descriptor lists what builds that input and what
the output means (see agile/rl_env/rsl_rl/exporter.py). Also run by train.py at the end of training.
"""

from __future__ import annotations

import os

from agile.run import common as cli

from agile.run import multi_agent
from agile.run.common import load_runner
from agile.run.policy import inference_cfg


def export(task: str, env, agent_cfg, runner, out_dir: str) -> dict:
    """Write the three files; returns their paths."""
    from agile.rl_env.rsl_rl.exporter import export_policy, io_descriptor, write_io_descriptor

    jit_path, onnx_path = export_policy(runner, out_dir)
    descriptor_path = os.path.join(out_dir, "io_descriptor.yaml")
    write_io_descriptor(descriptor_path, io_descriptor(env, agent_cfg))
    return {"jit": jit_path, "onnx": onnx_path, "io_descriptor": descriptor_path}


def main(argv=None) -> None:
    parser = cli.new_parser(__doc__)
    cli.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (default: the shipped policy)")
    parser.add_argument("--out", required=True, help="output folder")
    cli.add_checkpoint_args(parser)
    args = cli.parse(parser, argv)
    if multi_agent.is_multi_agent(args.task):
        multi_agent.export_main(args)
        return
    if args.num_envs is None:
        args.num_envs = 1
    checkpoint = args.checkpoint or cli.shipped_policy(args)
    if checkpoint is None:
        cli.fail(f"no --checkpoint given and agile ships no policy for {args.task}")
    contents = cli.read_checkpoint(str(checkpoint), args.trust_checkpoint)
    env_cfg, agent_cfg, device = cli.load_task(args)
    env = cli.make_env(args.task, inference_cfg(env_cfg), device)
    paths = export(args.task, env, agent_cfg, load_runner(contents, env, agent_cfg), args.out)
    for kind, path in paths.items():
        print(f"[agile] {kind}: {path}")


if __name__ == "__main__":
    main()
