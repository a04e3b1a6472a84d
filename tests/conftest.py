"""Shared fixtures."""

from pathlib import Path

import pytest

from elastica_magnetic.reference import reference_field_csv


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    """Folder of the published pattern-1 4 mT field and trajectory (shipped with the package)."""
    return reference_field_csv().parent


@pytest.fixture(scope="session")
def fault_server(tmp_path_factory):
    """The warm parent of the fault-injection tests' ``msr`` processes (``tests/faults.py``):
    each command runs in a process of its own, forked from it."""
    from faults import FaultServer

    server = FaultServer(tmp_path_factory.mktemp("faults"))
    yield server
    server.close()


def pytest_collection_modifyitems(session, config, items):
    """The files holding a ``slow`` test go first, in collection order, the others after them.
    ``scripts/test.sh`` hands the workers whole files in this order (``--dist loadfile
    --no-loadscope-reorder``): a file of minutes started last would keep one worker busy while the
    other has nothing left (xdist's own order, most tests first, put the few-test, minute-long files
    last)."""
    slow_files = {item.path for item in items if item.get_closest_marker("slow")}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: each file keeps its order
