"""Export a policy: TorchScript (policy.pt), ONNX (policy.onnx) and the IO descriptor (io_descriptor.yaml), or a
LEAPP bundle (NVIDIA's deploy format).

    agile export --task Velocity-G1-History-v0 --out exported/g1          # the shipped policy
    agile export --task Velocity-T1-v0 --checkpoint logs/.../model_3000.pt --out exported/t1
    agile export --task Velocity-T1-v0 --format leapp --out exported/leapp   # exported/leapp/Velocity-T1-v0/

Both model files take the actor's observation groups concatenated, (batch, obs_dim), observation
normalisation included, and return the mean action. The descriptor lists what builds that input and what
the output means (see agile/export/io_descriptor.py). Also run by train.py at the end of training.

A LEAPP bundle (<Task>.yaml, <Task>.onnx, <Task>_initial_values.safetensors) takes raw robot state and gives joint
position targets: the observation terms, history, normaliser and action terms are inside the graph, and the last
action, histories and recurrent state are fed back by LEAPP's runtime (see agile/export/leapp_bundle.py).
Run it in plain MuJoCo with `agile sim2mujoco --bundle <out>/<Task>/<Task>.yaml`.
"""

from __future__ import annotations

import os

from agile.run import common as cli

from agile.run import multi_agent
from agile.run.common import load_runner
from agile.run.policy import inference_cfg


def export(task: str, env, agent_cfg, runner, out_dir: str) -> dict:
    """Write the three files; returns their paths."""
    from agile.export.io_descriptor import io_descriptor
    from agile.export.policy_files import export_policy
    from agile.rl_env.io_descriptor_file import write_io_descriptor

    jit_path, onnx_path = export_policy(runner, out_dir)
    descriptor_path = os.path.join(out_dir, "io_descriptor.yaml")
    write_io_descriptor(descriptor_path, io_descriptor(env, agent_cfg))
    return {"jit": jit_path, "onnx": onnx_path, "io_descriptor": descriptor_path}


def export_leapp(env, agent_cfg, runner, out_dir: str) -> dict:
    """Write the LEAPP bundle into `out_dir/<task>/`; returns its YAML's path."""
    try:
        import leapp  # noqa: F401
    except ImportError:
        cli.fail("--format leapp needs the leapp package: pip install 'agile[leapp]'")
    from agile.export.io_descriptor import io_descriptor
    from agile.export.leapp_bundle import UnsupportedPolicyError, write_bundle

    try:
        return {"leapp": write_bundle(io_descriptor(env, agent_cfg), runner.alg.get_policy().as_onnx(verbose=False),
                                      out_dir)}
    except UnsupportedPolicyError as err:
        cli.fail(f"--format leapp: {err}")


def main(argv=None) -> None:
    parser = cli.new_parser(__doc__)
    cli.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (default: the shipped policy)")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--format", choices=["torchscript", "leapp"], default="torchscript",
                        help="torchscript: policy.pt, policy.onnx and io_descriptor.yaml; leapp: a LEAPP bundle in "
                             "<out>/<task>/ (raw robot state in, joint targets out)")
    cli.add_checkpoint_args(parser)
    args = cli.parse(parser, argv)
    if multi_agent.is_multi_agent(args.task):
        if args.format != "torchscript":
            cli.fail(f"--format {args.format}: a multi-agent task exports each group's policy as TorchScript")
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
    runner = load_runner(contents, env, agent_cfg)
    paths = (export_leapp(env, agent_cfg, runner, args.out) if args.format == "leapp"
             else export(args.task, env, agent_cfg, runner, args.out))
    for kind, path in paths.items():
        print(f"[agile] {kind}: {path}")


if __name__ == "__main__":
    main()
