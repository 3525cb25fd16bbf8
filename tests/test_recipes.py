"""`--recipe fast`: its overrides go before the ones given (which win), it trains (CPU: the captured update falls
back to the eager one), and an unknown name is refused listing the known ones."""

from __future__ import annotations

import yaml
from commands import FLAT_GROUND_ARGS, run_command

from agile.run import arguments, task_setup
from agile.run.recipes import RECIPES


def parser_with_recipe():
    parser = arguments.new_parser("test")
    arguments.add_common_args(parser)
    arguments.add_recipe_arg(parser)
    return parser


def test_recipe_overrides_come_first_and_the_given_ones_win():
    args = arguments.parse(parser_with_recipe(), ["--task", "Velocity-T1-v0", "--device", "cpu", "--recipe", "fast",
                                            "agent.algorithm.desired_kl=0.015"])
    assert args.overrides == [*RECIPES["fast"], "agent.algorithm.desired_kl=0.015"]
    _, agent_cfg, _ = task_setup.load_task(**arguments.task_options(args))
    assert agent_cfg.algorithm.captured_update is True
    assert agent_cfg.algorithm.use_mixed_precision is True and agent_cfg.float32_matmul_precision == "high"
    assert agent_cfg.algorithm.desired_kl == 0.015


def test_an_unknown_recipe_is_refused_naming_the_known_ones():
    code, _, err = run_command("train", "--task", "Velocity-T1-v0", "--recipe", "slow")
    assert code == 2 and "invalid choice: 'slow'" in err and "'fast'" in err, err


def test_train_with_the_fast_recipe(tmp_path):
    code, out, err = run_command("train", "--task", "Velocity-T1-v0", "--device", "cpu", "--num_envs", "2",
                                 "--max_iterations", "1", "--log_root", str(tmp_path), "--recipe", "fast",
                                 "agent.num_steps_per_env=4", *FLAT_GROUND_ARGS)
    assert code == 0, out + err
    (run_dir,) = (tmp_path / "velocity_t1").iterdir()
    agent = yaml.safe_load((run_dir / "params" / "agent.yaml").read_text())
    assert agent["algorithm"]["captured_update"] is True and agent["algorithm"]["desired_kl"] == 0.02
    assert list(run_dir.glob("model_*.pt"))  # trained and saved
