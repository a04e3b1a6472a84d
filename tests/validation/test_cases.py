"""Every validation case in its --quick form, through `msr validate`, as a user runs it."""

import json

import pytest

from elastica_magnetic.cli import main
from validation.cli import CASES, available_cases


@pytest.mark.parametrize("case", list(CASES))
def test_validate_quick(case, tmp_path, capsys):
    if case not in available_cases():
        pytest.fail(f"validation case {case} is not implemented")
    status = main(["validate", case, "--quick", "--out", str(tmp_path), "--json"])
    result = json.loads(capsys.readouterr().out)
    (case_result,) = result["cases"]
    failed = [c for c in case_result["comparisons"] if not c["passed"]]
    assert status == 0 and result["passed"], f"failed comparisons: {failed}"
    assert case_result["n_compared"] >= 2
    report = (tmp_path / "report.md").read_text()
    assert case in report
    for figure in case_result["figures"]:
        assert (tmp_path / figure).exists() or __import__("pathlib").Path(figure).exists()


def test_unknown_case_is_a_clear_error(tmp_path, capsys):
    assert main(["validate", "nonsense", "--out", str(tmp_path)]) == 2
    assert "unknown case(s) nonsense" in capsys.readouterr().err
