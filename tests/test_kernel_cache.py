"""numba's on-disk cache and the package's guard against its stale kernels
(``elastica_magnetic._kernel_cache``): a kernel cached with another module's kernel inside it keeps
the old callee after that module changes; the guard drops the cached kernels when any module of the
package changed."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from elastica_magnetic import _kernel_cache
from elastica_magnetic._kernel_cache import STAMP_NAME, drop_stale_kernels

CALLEE = "from numba import njit\n\n\n@njit(cache=True)\ndef value():\n    return {value}\n"
CALLER = ("from numba import njit\n\nfrom .callee import value\n\n\n"
          "@njit(cache=True)\ndef twice():\n    return 2 * value()\n")


def _package(root: Path, value: int) -> Path:
    package = root / "kernels_pkg"
    package.mkdir(exist_ok=True)
    (package / "__init__.py").write_text("")
    (package / "callee.py").write_text(CALLEE.format(value=value))
    (package / "caller.py").write_text(CALLER)
    return package


def _twice(root: Path, guard: bool) -> int:
    """``caller.twice()`` in a fresh interpreter (numba's cache on disk), the guard run first or not."""
    code = textwrap.dedent(f"""
        from pathlib import Path
        from elastica_magnetic._kernel_cache import drop_stale_kernels
        if {guard}:
            drop_stale_kernels(Path({str(root / "kernels_pkg")!r}))
        from kernels_pkg.caller import twice
        print(twice())
    """)
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(root)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, env=env,
                         cwd=root)
    return int(out.stdout.split()[-1])


def test_a_cached_caller_keeps_its_old_callee_and_the_guard_drops_it(tmp_path):
    """The trap itself (numba's cache keys a kernel on its own file), then the guard's cure: the
    callee's module edited, the caller's cached kernel still returns the old value without the guard
    and the new one with it."""
    _package(tmp_path, 1)
    assert _twice(tmp_path, guard=False) == 2
    _package(tmp_path, 21)  # the callee's module changes (its size and time), the caller's does not
    assert _twice(tmp_path, guard=False) == 2  # stale: numba's cache kept the old callee
    assert _twice(tmp_path, guard=True) == 42
    assert _twice(tmp_path, guard=True) == 42  # the stamp now matches: the fresh cache is kept


@pytest.fixture
def in_tree_cache(monkeypatch):
    """numba's cache in the package's ``__pycache__`` (no ``NUMBA_CACHE_DIR``)."""
    from numba.core import config

    monkeypatch.setattr(config, "CACHE_DIR", "")


def test_the_guard_clears_only_numba_files_and_only_when_a_module_changed(tmp_path, in_tree_cache):
    package = _package(tmp_path, 1)
    cache = package / "__pycache__"
    cache.mkdir()
    kept = [cache / "caller.cpython-311.pyc", cache / "notes.txt"]
    for path in kept:
        path.write_text("x")

    def cached() -> list[Path]:
        files = [cache / "caller.twice-6.py311.nbi", cache / "caller.twice-6.py311.1.nbc"]
        for path in files:
            path.write_text("x")
        return files

    files = cached()
    assert drop_stale_kernels(package) == [cache]  # no stamp yet: whatever is cached may be stale
    assert not any(path.exists() for path in files) and all(path.exists() for path in kept)
    assert (cache / STAMP_NAME).read_text() == _kernel_cache.modules_stamp(package)
    files = cached()
    assert drop_stale_kernels(package) == []  # nothing changed: the cache stays
    assert all(path.exists() for path in files)
    (package / "callee.py").write_text(CALLEE.format(value=22))
    assert drop_stale_kernels(package) == [cache]
    assert not any(path.exists() for path in files) and all(path.exists() for path in kept)


def test_the_guard_finds_numba_cache_dir(tmp_path, monkeypatch):
    """With ``NUMBA_CACHE_DIR`` numba keeps a package's kernels in a subfolder of it named for the
    package's folder: the guard clears that one."""
    from numba.core import caching, config

    package = _package(tmp_path, 1)
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "numba-cache"))
    folder = tmp_path / "numba-cache" / caching.UserProvidedCacheLocator.get_suitable_cache_subpath(
        str(package / "callee.py"))
    folder.mkdir(parents=True)
    index = folder / "callee.value-5.py311.nbi"
    index.write_text("x")
    assert drop_stale_kernels(package) == [folder]
    assert not index.exists()


def test_the_package_left_its_stamp_at_import():
    """Importing the package ran the guard on its own folder: its cache folder holds the stamp of
    its modules as they are (unless no cache folder can be written)."""
    package = Path(_kernel_cache.__file__).resolve().parent
    folders = _kernel_cache.cache_folders(package)
    if not folders:
        pytest.skip("numba has no cache folder for the package here")
    assert any((folder / STAMP_NAME).read_text() == _kernel_cache.modules_stamp(package)
               for folder in folders if (folder / STAMP_NAME).is_file())
