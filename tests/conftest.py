"""Shared fixtures."""

from pathlib import Path

import pytest

from elastica_magnetic.reference import reference_field_csv


@pytest.fixture(scope="session")
def reference_dir() -> Path:
    """Folder of the published pattern-1 4 mT field and trajectory (shipped with the package)."""
    return reference_field_csv().parent
