"""The repository's text is written as things stand, not as a log of how they were reached: no "s27", no "the
twenty-seventh session", no "over three sessions" in any tracked text file (docs, README, code comments, result
files and their names). A measurement is named by its date, issue and commit; its history is git's and the
changelog's."""

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

SESSION_NUMBER = re.compile(r"(?<![\w./-])s\d{1,2}(?!\w|://)")
"""A session number: "s27", "(s16)", "s24-s27"; not "s3://", "cuda/s1", "S45" (case matters) or "steps6"."""
SESSION_NAME = re.compile(r"(?:^|[_\-./])s\d{1,2}(?=[_\-./]|$)|session\d+", re.I)
"""A session number in a file name: "eval_s27.json", "turn_in_place_s20/", "curves_session10.png"."""
SESSION_WORD = re.compile(r"\bsessions?\b", re.I)
"""Any "session", unless the line uses the word as a library's API does (below)."""
API_SESSION = re.compile(r"""scope=["']session|self\.session|\bsession\s*=\s*\w|\bsession\.\w|[(,]\s*session\s*[,:)]|`session`"""
                         r"|InferenceSession")
"""pytest's `scope="session"`, an ONNX Runtime `session`: code, not wording."""


def log_wording(line: str) -> str | None:
    """The log wording in one line of text, or None."""
    match = SESSION_NUMBER.search(line)
    if match:
        return match.group(0)
    match = SESSION_WORD.search(line)
    if match and not API_SESSION.search(line):
        return match.group(0)
    return None


def tracked_text_files() -> list[Path]:
    names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    return [ROOT / name for name in names.decode().split("\0") if name]


def findings() -> list[str]:
    found = []
    this_file = Path(__file__).resolve()
    for path in tracked_text_files():
        rel = path.relative_to(ROOT).as_posix()
        if SESSION_NAME.search(rel):
            found.append(f"{rel}: the file name")
        if path == this_file or not path.is_file():
            continue
        data = path.read_bytes()[:2_000_000]
        if b"\0" in data:  # binary: a policy, an image, a video
            continue
        for number, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), 1):
            word = log_wording(line)
            if word:
                found.append(f"{rel}:{number}: {word!r} in {line.strip()[:120]!r}")
    return found


def test_no_tracked_text_file_is_written_as_a_log():
    found = findings()
    assert not found, f"{len(found)} lines written as a log (name the date, issue and commit instead):\n" + \
        "\n".join(found[:200])


def test_the_patterns_catch_log_wording_and_spare_api_names():
    for line in ("training speed (s27) on the H100", "the twenty-seventh session measured", "over six sessions",
                 "(docs/stand_up.md, twenty-fourth session), and", "time to policy, sixteenth session).",
                 "benchmarks.md s27: log to log", "in this session", "s24-s27"):
        assert log_wording(line), line
    for line in ('@pytest.fixture(scope="session")', "self.session = session", "action = self.session.run(names)",
                 "ort.InferenceSession(path)", "s3://bucket/key", "S45, C45 = 1, 2", "fast_steps6", "0.5 s each",
                 "cuda/s1", "--seeds 0 1 2"):
        assert not log_wording(line), line
    assert SESSION_NAME.search("docs/results/eval_s27.json") and SESSION_NAME.search("turn_in_place_s20/a.json")
    assert SESSION_NAME.search("climb_curves_session10.png") and not SESSION_NAME.search("fast_steps6_2026-11-27.png")
