"""Dropping the package's numba kernels cached on disk when any of its modules changed (private).

numba's cache (``@njit(cache=True)``) checks a cached kernel against the time stamp of the kernel's
own file only. A kernel compiled with a kernel of another module inside it keeps the callee it was
compiled with: after an edit or a ``git pull`` in an editable install, the batched coils'
``coil_loops_forcing`` would run the old ``loops_field`` while the per-rod path runs the new one, a
silently inconsistent result. So at import the package compares a stamp of its modules (names, sizes,
modification times) with the one it left in each cache folder, and where they differ deletes that
folder's cached kernels (``.nbi`` index and ``.nbc`` code files) before any kernel loads: they compile
again, once.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

#: The stamp's file name in a cache folder.
STAMP_NAME = "elastica_magnetic.kernels-stamp"
#: numba's cache files: an index per kernel and its compiled code.
CACHE_PATTERNS = ("*.nbi", "*.nbc")


def modules_stamp(package_dir: Path) -> str:
    """A digest of the names, sizes and modification times (ns) of the ``*.py`` files directly in
    ``package_dir`` (the kernels' modules)."""
    digest = hashlib.sha1()
    for path in sorted(package_dir.glob("*.py")):
        stat = path.stat()
        digest.update(f"{path.name}\0{stat.st_size}\0{stat.st_mtime_ns}\n".encode())
    return digest.hexdigest()


def cache_folders(package_dir: Path) -> list[Path]:
    """The folders where numba keeps this package's kernels, as its cache locators choose them:
    ``NUMBA_CACHE_DIR``'s subfolder for the package when it is set, else the package's
    ``__pycache__`` and numba's user-wide folder (used where the package's folder is read-only).
    Only the folders that exist."""
    folders = []
    try:
        from numba.core import caching, config

        any_module = str(package_dir / "__init__.py")
        if config.CACHE_DIR:
            subpath = caching.UserProvidedCacheLocator.get_suitable_cache_subpath(any_module)
            folders.append(Path(config.CACHE_DIR) / subpath)
        else:
            folders.append(package_dir / "__pycache__")
            user_wide = caching.UserWideCacheLocator(drop_stale_kernels, any_module).get_cache_path()
            folders.append(Path(user_wide))
    except (ImportError, AttributeError, TypeError):  # another numba's internals: the in-tree folder
        folders = [package_dir / "__pycache__"]
    return [folder for folder in folders if folder.is_dir()]


def drop_stale_kernels(package_dir: Path) -> list[Path]:
    """Delete the cached kernels in each of :func:`cache_folders` whose stamp is not this
    :func:`modules_stamp` (or that has none), and leave the stamp there. Returns the folders
    cleared. A folder that cannot be written is left as it is (numba then compiles or loads as
    it would)."""
    stamp = modules_stamp(package_dir)
    cleared = []
    for folder in cache_folders(package_dir):
        stamp_file = folder / STAMP_NAME
        try:
            if stamp_file.is_file() and stamp_file.read_text() == stamp:
                continue
            for pattern in CACHE_PATTERNS:
                for cached in folder.glob(pattern):
                    cached.unlink(missing_ok=True)
            # Written whole or not at all: another process may read it at the same time.
            partial = folder / f"{STAMP_NAME}.{os.getpid()}.tmp"
            partial.write_text(stamp)
            os.replace(partial, stamp_file)
            cleared.append(folder)
        except OSError:
            continue
    return cleared


drop_stale_kernels(Path(__file__).resolve().parent)
