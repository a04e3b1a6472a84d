"""docs/getting_started.md runs as written: every ``msr`` command of its ```bash blocks, in order, in
an empty folder, exits 0 and leaves the files its ``# writes:`` line names (and its output shows
what its ``# prints:`` line names); its install block is the README's two commands."""

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "getting_started.md"
MSR = Path(sys.executable).parent / "msr"


def _bash_lines(text: str) -> list[str]:
    return [line.strip() for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S)
            for line in block.splitlines() if line.strip()]


def page_steps() -> list[dict]:
    """The page's ``msr`` commands in order, each with the files it writes and the text it prints."""
    steps: list[dict] = []
    for line in _bash_lines(PAGE.read_text()):
        if line.startswith("msr "):
            steps.append({"command": line, "writes": [], "prints": []})
        elif line.startswith("# writes:") and steps:
            steps[-1]["writes"] += line.removeprefix("# writes:").split()
        elif line.startswith("# prints:") and steps:
            steps[-1]["prints"].append(line.removeprefix("# prints:").strip())
    return steps


def test_the_install_block_is_the_readmes_two_commands():
    readme = _bash_lines((ROOT / "README.md").read_text())[:2]
    assert [c.split("#")[0].strip() for c in readme] == ["bash scripts/main.sh", "bash scripts/test.sh"]
    others = [line for line in _bash_lines(PAGE.read_text())
              if not line.startswith(("msr ", "#"))]
    assert others == [*readme, "source .venv/bin/activate"]


def test_the_page_covers_the_first_path():
    commands = [" ".join(s["command"].split()[:3]) for s in page_steps()]
    for expected in ("msr policy demo", "msr case list", "msr case show", "msr train --case",
                     "msr policy generate", "msr policy export"):
        assert any(c.startswith(expected) for c in commands), expected
    assert all(s["writes"] or s["prints"] for s in page_steps())


@pytest.mark.slow
def test_the_pages_commands_run_in_an_empty_folder(tmp_path):
    env = {**os.environ, "MPLBACKEND": "Agg"}
    for step in page_steps():
        argv = [str(MSR), *shlex.split(step["command"])[1:]]
        done = subprocess.run(argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
        assert done.returncode == 0, f"{step['command']}\n{done.stdout}\n{done.stderr}"
        for path in step["writes"]:
            assert (tmp_path / path).is_file(), f"{step['command']} did not write {path}"
        for text in step["prints"]:
            assert text in done.stdout, f"{step['command']} did not print {text!r}:\n{done.stdout}"
