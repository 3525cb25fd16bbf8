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

import dataclasses
import os

from agile.run import arguments, task_setup
from agile.errors import AgileError

from agile.run.task_kinds import run_command
from agile.run.arguments import command
from agile.run.policy import inference_cfg


EXPORT_FORMATS = ("torchscript", "leapp")


@dataclasses.dataclass(frozen=True)
class ExportOptions:
    """Everything `agile export` exports with, for a task of any kind (`agile.run.task_kinds`: the kind's export
    function takes it): `export_checkpoint`'s keyword arguments (`num_envs` None: 1); a multi-agent task's
    `checkpoint` is its training run folder."""
    task: str
    out_dir: str
    checkpoint: str | None = None
    format: str = "torchscript"
    device: str | None = None
    num_envs: int | None = None
    seed: int | None = None
    rnn: str | None = None
    overrides: tuple = ()
    trust_checkpoint: bool = False
    collect_datasets_anew: bool = False


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
        raise AgileError("--format leapp needs the leapp package: pip install 'agile[leapp]'")
    from agile.export.io_descriptor import io_descriptor
    from agile.export.leapp_bundle import UnsupportedPolicyError, write_bundle

    try:
        return {"leapp": write_bundle(io_descriptor(env, agent_cfg), runner.alg.get_policy().as_onnx(verbose=False),
                                      out_dir)}
    except UnsupportedPolicyError as err:
        raise AgileError(f"--format leapp: {err}")


def export_checkpoint(*, task: str, out_dir: str, checkpoint: str | None = None, format: str = "torchscript",
                      device: str | None = None, num_envs: int = 1, seed: int | None = None, rnn: str | None = None,
                      overrides: list[str] | tuple = (), trust_checkpoint: bool = False,
                      collect_datasets_anew: bool = False) -> dict:
    """Export `checkpoint` (default: the policy agile ships for `task`) into `out_dir`: `format` "torchscript"
    (policy.pt, policy.onnx, io_descriptor.yaml) or "leapp" (a bundle in out_dir/<task>/). Builds one env of the task
    (`num_envs` of them, with `overrides`) to describe the policy's inputs and outputs. Returns {kind: path} of what
    it wrote."""
    if format not in EXPORT_FORMATS:
        raise AgileError(f"format must be one of {', '.join(EXPORT_FORMATS)}, got {format!r}")
    task_setup.check_writable(out_dir, "out_dir")
    checkpoint, overrides = task_setup.policy_to_run(task=task, checkpoint=checkpoint, overrides=overrides)
    contents = task_setup.read_checkpoint(checkpoint, trust_checkpoint)
    env_cfg, agent_cfg, device = task_setup.load_task(task=task, num_envs=num_envs, device=device, seed=seed, rnn=rnn,
                                                 overrides=overrides)
    env = task_setup.make_env(task=task, env_cfg=inference_cfg(env_cfg), device=device,
                         collect_datasets_anew=collect_datasets_anew)
    try:
        runner = task_setup.load_runner(contents, env, agent_cfg)
        return (export_leapp(env, agent_cfg, runner, out_dir) if format == "leapp"
                else export(task, env, agent_cfg, runner, out_dir))
    finally:
        env.close()


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    arguments.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (default: the shipped policy)")
    parser.add_argument("--out", required=True, help="output folder")
    parser.add_argument("--format", choices=EXPORT_FORMATS, default="torchscript",
                        help="torchscript: policy.pt, policy.onnx and io_descriptor.yaml; leapp: a LEAPP bundle in "
                             "<out>/<task>/ (raw robot state in, joint targets out)")
    arguments.add_checkpoint_args(parser)
    args = arguments.parse(parser, argv)
    options = ExportOptions(task=args.task, out_dir=args.out, checkpoint=args.checkpoint, format=args.format,
                            device=args.device, num_envs=args.num_envs, seed=args.seed, rnn=args.rnn,
                            overrides=tuple(args.overrides), trust_checkpoint=args.trust_checkpoint,
                            collect_datasets_anew=args.no_cache)
    for kind, path in run_command("export", options.task, options).items():
        print(f"[agile] {kind}: {path}")


def export_single_agent(options: ExportOptions) -> dict:
    """`agile export` for every kind but multi-agent (`agile.run.task_kinds`): `export_checkpoint`'s {kind: path}."""
    return export_checkpoint(task=options.task, out_dir=options.out_dir, checkpoint=options.checkpoint,
                             format=options.format, device=options.device, num_envs=options.num_envs or 1,
                             seed=options.seed, rnn=options.rnn, overrides=options.overrides,
                             trust_checkpoint=options.trust_checkpoint,
                             collect_datasets_anew=options.collect_datasets_anew)


if __name__ == "__main__":
    main()
