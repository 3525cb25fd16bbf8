"""agile plot_learning_curve: run folders (and a multi-agent run's group folders) read, resumed runs joined."""

import pytest

from commands import run_command


def test_learning_curve_resumption_replaces_the_abandoned_branch():
    from agile.run.plot_learning_curve import join_resumed

    run = [(0, 0.0), (1, 1.0), (2, 2.0), (3, 3.0)]
    resumed_from_1 = [(1, 10.0), (2, 20.0), (3, 30.0), (4, 40.0)]
    steps, values = join_resumed([run, [], resumed_from_1])
    assert steps == [0, 1, 2, 3, 4]
    assert values == [0.0, 10.0, 20.0, 30.0, 40.0]
    assert join_resumed([run, [(4, 4.0)]]) == ([0, 1, 2, 3, 4], [0.0, 1.0, 2.0, 3.0, 4.0])


def _write_run(folder, values: dict[str, list[float]], start: int = 0) -> None:
    from torch.utils.tensorboard import SummaryWriter

    writer = SummaryWriter(log_dir=str(folder))
    for tag, series in values.items():
        for i, value in enumerate(series):
            writer.add_scalar(tag, value, start + i)
    writer.close()


def test_learning_curve_reads_run_folders_and_agent_groups(tmp_path):
    from agile.run.plot_learning_curve import curves_of, read_run

    _write_run(tmp_path / "run_a", {"Train/mean_reward": [1.0, 2.0, 3.0]})
    _write_run(tmp_path / "run_b", {"Train/mean_reward": [20.0, 30.0]}, start=1)  # resumed from iteration 1
    [(label, files)] = curves_of(None, [str(tmp_path / "run_a")])
    assert label == "run_a" and len(files) == 1
    [(label, files)] = curves_of("joined", [str(tmp_path / "run_a"), str(tmp_path / "run_b")])
    assert read_run(files)["Train/mean_reward"] == ([0, 1, 2], [1.0, 20.0, 30.0])
    _write_run(tmp_path / "marl" / "g1", {"Loss/value_function": [0.5]})  # a multi-agent run: a folder per group
    _write_run(tmp_path / "marl" / "t1", {"Loss/value_function": [0.7]})
    curves = curves_of(None, [str(tmp_path / "marl")])
    assert [label for label, _ in curves] == ["marl/g1", "marl/t1"]
    assert read_run(curves[1][1])["Loss/value_function"] == ([0], [pytest.approx(0.7)])


def test_learning_curve_refuses_a_folder_without_logs(tmp_path):
    (tmp_path / "empty").mkdir()
    code, _, err = run_command("plot_learning_curve", str(tmp_path / "empty"))
    assert code != 0 and "no tensorboard event files" in err
