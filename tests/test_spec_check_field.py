""":func:`~elastica_magnetic.spec_check.check_spec` builds a spec's ``[field]`` in space as ``msr
simulate`` does (issue 48, a held-out round of tries, sf_*): a unit mistake or a source on the
rod is the same :class:`SpecError`."""

from __future__ import annotations

from pathlib import Path

import pytest

from elastica_magnetic.spec_check import check_spec
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import SpecError

CATHETER = Path(__file__).resolve().parents[1] / "elastica_magnetic" / "data" / "examples" / "catheter.toml"


def test_check_spec_refuses_a_field_in_mm_as_describe_field_does():
    text = CATHETER.read_text()
    text = text[:text.index("[field]")] + ('[field]\nkind = "cylinder-magnet"\ndiameter = 4\nheight = 4\n'
                                            "polarization = [0, 0, 1.3]\nposition = [0.03, 0.03, 0.0]\n")
    with pytest.raises(SpecError, match=r"^cath\.toml: \[field\] diameter = 4 m is above 1 m, larger than "
                                        r"any permanent magnet block; it looks like mm or cm"):
        check_spec(loads(text, "cath.toml"), "cath.toml", sag=False)


def test_check_spec_of_the_example_catheter_builds_its_field():
    check = check_spec(loads(CATHETER.read_text(), "catheter.toml"), "catheter.toml", sag=False)
    assert not check.has_errors
