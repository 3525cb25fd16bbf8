"""Nothing runs code from a checkpoint, and the viewer listens on this machine only unless told otherwise."""

import socket
from pathlib import Path

import pytest
import torch
from commands import FLAT_GROUND_ARGS, run_command
from evil_payload import Payload

from agile.rl.checkpoints import UntrustedCheckpointError, load_checkpoint

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted((ROOT / "agile" / "data" / "policy").glob("*.pt"))


def run(script, *args, timeout=600):
    """(exit code, stdout and stderr) of `python scripts/<command>.py ARGS`, in this process (the payload's module
    is importable here, so an unsafe load would run it)."""
    code, out, err = run_command(Path(script).stem, *args, cwd=ROOT)
    return code, out + err


@pytest.fixture
def evil_checkpoint(tmp_path):
    """The shipped T1 policy with an object that writes `marker` when unpickled."""
    marker = tmp_path / "marker.txt"
    contents = torch.load(ROOT / "agile" / "data" / "policy" / "Velocity-T1-v0.pt", weights_only=True)
    contents["infos"] = {"note": Payload(str(marker))}
    path = tmp_path / "evil.pt"
    torch.save(contents, path)
    return path, marker


def test_shipped_policies_hold_only_tensors_and_containers():
    assert SHIPPED
    for path in SHIPPED:
        contents = load_checkpoint(str(path))
        # the acting model's weights only: a PPO policy's actor, a distilled student's student
        assert [key for key in contents if key.endswith("_state_dict")] in (["actor_state_dict"],
                                                                          ["student_state_dict"]), path


def test_loading_refuses_a_checkpoint_that_would_run_code(evil_checkpoint):
    path, marker = evil_checkpoint
    with pytest.raises(UntrustedCheckpointError, match=r"'evil_payload.write_marker'.*--trust_checkpoint"):
        load_checkpoint(str(path))
    assert not marker.exists()
    load_checkpoint(str(path), trust=True)  # the user's explicit choice: the old, code-running way
    assert marker.exists()


@pytest.mark.parametrize("command", [
    ["scripts/play.py", "--task", "Velocity-T1-v0", "--num_steps", "2"],
    ["scripts/eval.py", "--task", "Velocity-T1-v0", "--episode_length_s", "0.1"],
    ["scripts/export.py", "--task", "Velocity-T1-v0", "--out", "{tmp}/exported"],
    ["scripts/train.py", "--task", "Velocity-T1-v0", "--max_iterations", "1", "--log_root", "{tmp}/logs", "--resume"],
    ["scripts/train.py", "--task", "Velocity-T1-v0", "--max_iterations", "1", "--log_root", "{tmp}/logs",
     "--init_policy", "{checkpoint}"],
], ids=["play", "eval", "export", "resume", "init_policy"])
def test_every_script_refuses_it_at_once(evil_checkpoint, command, tmp_path):
    path, marker = evil_checkpoint
    args = [a.format(tmp=tmp_path, checkpoint=path) for a in command]
    if "--init_policy" not in args:
        args += ["--checkpoint", str(path)]
    code, out = run(*args, "--device", "cpu", "--num_envs", "2")
    assert code != 0 and "refused" in out and "--trust_checkpoint" in out, out
    assert "Traceback" not in out, out  # one line, not a stack
    assert not marker.exists()


def test_trust_checkpoint_loads_it_the_old_way(evil_checkpoint, tmp_path):
    path, marker = evil_checkpoint
    code, out = run("scripts/export.py", "--task", "Velocity-T1-v0", "--checkpoint", str(path), "--device", "cpu",
                    "--out", str(tmp_path / "exported"), "--trust_checkpoint", *FLAT_GROUND_ARGS)
    assert code == 0, out
    assert marker.exists() and (tmp_path / "exported" / "policy.onnx").is_file()


def listening_addresses(port: int) -> set[str]:
    """Local IPv4 addresses with a socket listening on `port` (from /proc/net/tcp)."""
    found = set()
    for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
        local, state = line.split()[1], line.split()[3]
        address, port_hex = local.split(":")
        if state == "0A" and int(port_hex, 16) == port:  # 0A: LISTEN
            found.add(socket.inet_ntoa(bytes.fromhex(address)[::-1]))
    return found


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.skipif(not Path("/proc/net/tcp").exists(), reason="reads the listening sockets from /proc (Linux)")
def test_viewer_listens_on_loopback_unless_a_host_is_given(capsys):
    import gymnasium as gym

    import agile.tasks  # noqa: F401
    from agile.gui import BrowserViewer

    env = gym.make("Debug-T1-v0", device="cpu").unwrapped
    port = free_port()
    viewer = BrowserViewer(env, port)
    try:
        assert listening_addresses(port) == {"127.0.0.1"}
    finally:
        viewer.close()
    assert "warning" not in capsys.readouterr().out
    port = free_port()
    viewer = BrowserViewer(env, port, host="0.0.0.0")
    try:
        assert listening_addresses(port) == {"0.0.0.0"}
    finally:
        viewer.close()
    assert "warning: the viewer listens on 0.0.0.0" in capsys.readouterr().out


def test_a_cache_in_a_folder_others_can_write_is_loaded_with_a_warning(tmp_path, monkeypatch):
    import warnings

    from test_terrain import STAIRS

    from agile.sim.terrain import cache_dir, load_or_generate_terrain

    monkeypatch.setenv("AGILE_CACHE_DIR", str(tmp_path))
    load_or_generate_terrain(STAIRS)  # writes the cache with the user's permissions
    assert not cache_dir().stat().st_mode & 0o002
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_or_generate_terrain(STAIRS)  # a private folder: no warning
    cache_dir().chmod(0o777)
    with pytest.warns(UserWarning, match="world-writable"):
        load_or_generate_terrain(STAIRS)
