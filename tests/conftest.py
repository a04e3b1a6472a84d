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
