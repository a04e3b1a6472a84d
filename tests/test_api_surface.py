"""The physics package's top level (issue 50): every exported name exists, the errors end in
``Error`` (the earlier names are aliases of the same classes), and the export list is grouped by
concept, sorted within each group."""

from __future__ import annotations

import inspect
import re
from pathlib import Path

import elastica_magnetic as em


def test_every_exported_name_exists_once():
    assert len(em.__all__) == len(set(em.__all__))
    assert [name for name in em.__all__ if not hasattr(em, name)] == []


def test_every_exported_error_ends_in_error_and_old_names_are_aliases():
    errors = [name for name in em.__all__
              if inspect.isclass(getattr(em, name)) and issubclass(getattr(em, name), Exception)]
    assert errors and all(name.endswith("Error") for name in errors), errors
    for old in ("SimulationDiverged", "BatchedSimulationDiverged", "SpatialFieldNotSupported"):
        assert getattr(em, old) is getattr(em, old + "Error") and old not in em.__all__
    assert issubclass(em.BatchedSimulationDivergedError, em.SimulationDivergedError)


def test_the_export_list_is_grouped_and_sorted_within_each_group():
    text = Path(em.__file__).read_text()
    block = text[text.index("__all__ = ["):text.index("]", text.index("__all__ = ["))]
    groups: list[list[str]] = []
    for line in block.splitlines()[1:]:
        if line.strip().startswith("#"):
            groups.append([])
        elif match := re.search(r'"([^"]+)"', line):
            groups[-1].append(match.group(1))
    assert len(groups) == 6 and sum(len(g) for g in groups) == len(em.__all__)
    for names in groups:
        assert names == sorted(names, key=lambda n: (n.lower(), n)), names


def test_the_learning_package_exports_what_a_script_needs_without_importing_torch():
    """``import elastica_magnetic_rl`` stays light (registers the environment, imports no torch);
    each exported name loads its module when first used."""
    import subprocess
    import sys

    code = ("import sys, elastica_magnetic_rl as r; assert 'torch' not in sys.modules; "
            "missing = [n for n in r.__all__ if getattr(r, n, None) is None]; "
            "assert not missing, missing; print(len(r.__all__))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) >= 15
