"""The process backend's job runner: results in job order, errors reported or raised."""

from __future__ import annotations

import math

import pytest
from elastica_magnetic_rl.sweep.backends import run_in_processes


def test_results_keep_the_job_order_and_a_failing_job_is_reported():
    out = run_in_processes(math.sqrt, [9.0, 4.0, -1.0, 16.0], 2,
                           on_error=lambda k, exc: f"job {k}: {exc}")
    assert out == [3.0, 2.0, "job 2: math domain error", 4.0]


def test_without_an_error_handler_the_jobs_exception_is_raised():
    with pytest.raises(ValueError, match="math domain error"):
        run_in_processes(math.sqrt, [4.0, -1.0, 9.0], 2)
