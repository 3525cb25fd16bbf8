"""The errors of an evaluation by commanded value (agile.run.metric_breakdowns): bins, standard errors, tables."""

import pytest


def test_error_by_command_bins_hand_values():
    import torch
    from agile.run.metric_breakdowns import ErrorByCommand

    by_speed = ErrorByCommand((0.05, 0.5), "cpu")
    commanded = torch.tensor([0.0, 0.3, 0.4, 0.7])
    by_speed.add(commanded, torch.tensor([0.1, 0.2, 0.4, 0.6]), alive=torch.tensor([1.0, 1.0, 1.0, 0.0]))
    by_speed.add(commanded, torch.tensor([0.3, 0.2, 0.4, 0.8]), alive=torch.ones(4))
    rows = by_speed.rows()
    assert [row["command"] for row in rows] == [[0.0, 0.05], [0.05, 0.5], [0.5, None]]
    assert [row["steps"] for row in rows] == [2, 4, 1]  # the dead env's first step is not counted
    assert [row["error"] for row in rows] == pytest.approx([0.2, 0.3, 0.8])


def test_error_by_command_gives_each_bins_standard_error_over_the_envs():
    import torch
    from agile.run.metric_breakdowns import ErrorByCommand

    by_speed = ErrorByCommand((0.05,), "cpu")
    commanded = torch.zeros(3)  # three envs, all in the first bin
    by_speed.add(commanded, torch.tensor([0.1, 0.2, 0.6]), alive=torch.ones(3))
    by_speed.add(commanded, torch.tensor([0.3, 0.9, 0.9]), alive=torch.tensor([1.0, 0.0, 0.0]))
    (row,) = by_speed.rows()
    # env sums e = (0.4, 0.2, 0.6) over n = (2, 1, 1) steps: mean 1.2 / 4 = 0.3; residuals e - 0.3 n = (-0.2, -0.1, 0.3)
    assert row["error"] == pytest.approx(0.3) and (row["steps"], row["envs"]) == (4, 3)
    assert row["error_se"] == pytest.approx((3 / 2 * 0.14) ** 0.5 / 4)
    one_env = ErrorByCommand((0.05,), "cpu")
    one_env.add(torch.zeros(1), torch.tensor([0.2]), alive=torch.ones(1))
    assert one_env.rows()[0]["error_se"] is None  # no spread from one env


def test_error_by_command_tables_read_like_the_docs():
    from agile.run.metric_breakdowns import error_by_command_tables

    rows = [{"command": [0.0, 0.2], "error": 0.0486, "steps": 25}, {"command": [0.9, None], "error": 0.059, "steps": 75}]
    assert error_by_command_tables({"height_error_m_by_height_m": rows, "lin_vel_error_mps_by_speed_mps": []}) == (
        "| height_m | 0-0.2 | 0.9- |\n|---|---|---|\n| height_error_m | 0.049 | 0.059 |\n| share of steps | 25% | 75% |")
    with_se = [{**rows[0], "error_se": 0.0041}, {**rows[1], "error_se": None}]
    assert error_by_command_tables({"height_error_m_by_height_m": with_se}).splitlines()[3] == (
        "| standard error | 0.004 | - |")
