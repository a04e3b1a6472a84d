"""The wheel a user installs: the shipped policies, the case specs and the paper's reference data,
but not the seed campaigns committed under ``rl/policies/<case>/seeds/``; under 20 MB."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Largest acceptable wheel, bytes: every shipped policy adds its actor and critic (about 1.5 MB; 21.4 MB
#: with the 16 policies of 2026-12-06).
MAX_WHEEL_BYTES = 24 * 1024 * 1024


def _source_files() -> list[str]:
    """The checkout's files (tracked, and untracked ones git does not ignore)."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("needs a git checkout of the repository")
    out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "-z"],
                         cwd=ROOT, capture_output=True, check=True).stdout.decode()
    return [f for f in out.split("\0") if f and (ROOT / f).is_file()]


def test_the_wheel_holds_the_shipped_policies_and_no_seed_campaigns(tmp_path):
    # Built from a clean copy of the checkout: a stale build/ folder in the worktree could carry
    # files the current configuration leaves out.
    source = tmp_path / "src"
    files = _source_files()
    for name in files:
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, source / name)
    assert any("/seeds/" in f for f in files), "the checkout has no committed seeds to leave out"
    result = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation",
         "-q", "-w", str(tmp_path / "dist")],
        capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    (wheel,) = (tmp_path / "dist").glob("elastica_magnetic-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert not [n for n in names if "/seeds/" in n], [n for n in names if "/seeds/" in n][:5]
    shipped = sorted(p.name for p in (ROOT / "rl" / "policies").iterdir()
                     if (p / "policy.json").is_file())
    assert len(shipped) >= 4
    for name in shipped:
        for path in (ROOT / "rl" / "policies" / name).iterdir():
            if path.is_file():
                assert f"elastica_magnetic_rl/policies/{name}/{path.name}" in names
    specs = [p.name for p in (ROOT / "rl" / "specs").glob("*.toml")]
    assert specs and all(f"elastica_magnetic_rl/specs/{s}" in names for s in specs)
    data = [p.relative_to(ROOT).as_posix() for p in (ROOT / "elastica_magnetic" / "data").rglob("*")
            if p.is_file()]
    assert data and all(d in names for d in data)
    assert "elastica_magnetic/cli/app.py" in names and "elastica_magnetic_rl/cli/commands.py" in names
    assert "elastica_magnetic_rl/sim2real/cli.py" in names
    size = wheel.stat().st_size
    print(f"wheel {wheel.name}: {size / 1e6:.1f} MB, {len(names)} files")
    assert size < MAX_WHEEL_BYTES, f"{size / 1e6:.1f} MB"
