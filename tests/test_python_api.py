"""The runtime as a library: train -> evaluate -> export from Python without the command line, as
docs/howto/python_api.md shows it (its snippet runs here verbatim), and refused input raised as AgileError."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

from agile.errors import AgileError

GUIDE = Path(__file__).resolve().parents[1] / "docs" / "howto" / "python_api.md"


def guide_snippet() -> str:
    blocks = re.findall(r"```python\n(.*?)```", GUIDE.read_text(), flags=re.S)
    assert len(blocks) == 1, f"{GUIDE} should hold one Python snippet, holds {len(blocks)}"
    return blocks[0]


def test_the_guide_trains_evaluates_and_exports_from_python(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = io.StringIO()
    namespace = {}
    with contextlib.redirect_stdout(out):
        exec(compile(guide_snippet(), str(GUIDE), "exec"), namespace)  # noqa: S102 (the guide's own code)
    run, metrics, files = namespace["run"], namespace["metrics"], namespace["files"]
    assert run.log_dir.startswith("logs/rsl_rl/velocity_t1/") and Path(run.checkpoint).is_file()
    assert (Path(run.log_dir) / "params" / "env.yaml").is_file() and Path(run.exported["jit"]).is_file()
    assert metrics["checkpoint"] == run.checkpoint and metrics["num_envs"] == 2 and 0.0 <= metrics["fall_rate"] <= 1.0
    assert all(Path(files[kind]).is_file() for kind in ("jit", "onnx", "io_descriptor"))
    assert Path(files["jit"]).resolve().parent == tmp_path / "exported" / "t1"
    assert "refused: unknown task 'Velocity-Nope-v0'" in out.getvalue()


def test_refused_input_is_an_agile_error_naming_the_field_before_anything_is_built(tmp_path):
    from agile.run.eval import evaluate_checkpoint
    from agile.run.export import export_checkpoint
    from agile.run.task_setup import load_task
    from agile.run.train import train

    with pytest.raises(AgileError, match="unknown task 'Nope-v0'. Registered tasks: .*Velocity-T1-v0"):
        evaluate_checkpoint(task="Nope-v0")
    with pytest.raises(AgileError, match="format must be one of torchscript, leapp, got 'tflite'"):
        export_checkpoint(task="Velocity-T1-v0", out_dir=str(tmp_path), format="tflite")
    (tmp_path / "a_file").write_text("")
    with pytest.raises(AgileError, match="out_dir .*a_file is a file, not a folder"):
        export_checkpoint(task="Velocity-T1-v0", out_dir=str(tmp_path / "a_file" / "policy"))
    with pytest.raises(AgileError, match="progress must be one of auto, bar, log, got 'dots'"):
        train(task="Velocity-T1-v0", progress="dots")
    with pytest.raises(AgileError, match="rnn must be one of 'lstm', 'gru'"):
        load_task(task="Velocity-T1-v0", rnn="transformer")
    with pytest.raises(AgileError, match="num_envs must be at least 1, got 0"):
        load_task(task="Velocity-T1-v0", num_envs=0)
    with pytest.raises(AgileError, match="'agent' has no field 'nope'. Fields: \\['experiment_name'"):
        load_task(task="Velocity-T1-v0", device="cpu", overrides=["agent.nope=1"])
