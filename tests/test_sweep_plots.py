"""The pictures of agile eval's sweeps, drawn from their JSON alone (agile eval --plot_sweep: no --task, no env)."""

from __future__ import annotations

import json

import pytest

from agile.run import eval as eval_cli
from agile.run.sweep_plots import plot_sweep


def _write(path, **rows) -> str:
    result = {"task": "HeightTracking-G1-v0", "checkpoint": "/runs/model_10.pt", "device": "cpu", "num_envs": 4,
              "episodes_per_env": 1, "episode_length_s": 12.0, **rows}
    path.write_text(json.dumps(result))
    return str(path)


def _value_row(command: float, reached: list[float], fine: float) -> dict:
    ordered = sorted(reached)
    return {"command": command, "num_envs": len(reached), "episodes": 2, "falls": 0, "fall_rate": 0.0,
            "mean_abs_error_height_m": sum(abs(r - command) for r in reached) / len(reached),
            "mean_signed_error_height_m": sum(r - command for r in reached) / len(reached),
            "reached_height_m_p10_p50_p90": [ordered[0], ordered[len(ordered) // 2], ordered[-1]],
            "reached_height_m_per_env": ordered,
            "reward_per_step": {"total": fine - 1.0, "base_height_fine": fine, "joint_deviation_l1": -1.0}}


def test_a_command_sweep_is_drawn_next_to_its_json(tmp_path, capsys):
    json_path = _write(tmp_path / "heights.json", values=[
        _value_row(0.3, [0.21, 0.22], 12.0), _value_row(0.7, [0.58, 0.59], 10.0),
        {"command": 0.92, "num_envs": 2, "episodes": 2, "falls": 2, "fall_rate": 1.0}])  # every env fell
    png = plot_sweep(json_path)
    assert png == str(tmp_path / "heights.png") and (tmp_path / "heights.png").stat().st_size > 10_000
    assert "[agile] plot:" in capsys.readouterr().out


def test_a_grid_sweep_is_drawn_as_heat_maps(tmp_path):
    cells = [{"command": [vx, 0.0, 0.0], "fall_rate": 0.1 * i, "lin_vel_error_mps": 0.2, "episodes": 2}
             for i, vx in enumerate((0.0, 0.5, 1.0))]
    plot_sweep(_write(tmp_path / "grid.json", cells=cells))
    assert (tmp_path / "grid.png").stat().st_size > 10_000


def test_other_json_is_refused_naming_what_it_holds(tmp_path):
    with pytest.raises(ValueError, match=r"no 'cells' or 'values'; keys \[.*'task'"):
        plot_sweep(_write(tmp_path / "eval.json", fall_rate=0.1))


def test_the_cli_draws_without_a_task_and_needs_one_otherwise(tmp_path, capsys):
    json_path = _write(tmp_path / "heights.json", values=[_value_row(0.5, [0.5, 0.52], 15.0)])
    eval_cli.main(["--plot_sweep", json_path])
    assert (tmp_path / "heights.png").is_file()
    with pytest.raises(SystemExit):
        eval_cli.main(["--plot_sweep", str(tmp_path / "missing.json")])
    assert "missing.json: no such file" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        eval_cli.main(["--num_envs", "2"])
    assert "required: --task" in capsys.readouterr().err
