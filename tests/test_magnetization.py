"""The ``segments`` magnetization: a list of (elements or length fraction, direction, magnitude)
stretches; the paper's two named patterns written as segments give the same arrays bit for bit,
and every bad segment list is an error naming the file, the table, the segment and the key."""

from __future__ import annotations

import numpy as np
import pytest
from spec_texts import SMALL_BAND

from elastica_magnetic import (
    MagnetizationSegment,
    segments_magnetization,
    yao2023_magnetization,
    yao2023_robot,
)
from elastica_magnetic.magnetization import segment_element_counts
from elastica_magnetic.spec_format import loads
from elastica_magnetic.specfile import SpecError, describe_robot, dumps, magnetization_array

M = 61.3e3


@pytest.mark.parametrize("n", [64, 65, 7, 2])
def test_the_papers_patterns_as_segments_are_bit_for_bit_the_named_ones(n):
    for pattern, (back, front) in {1: ((-1, 0, 0), (1, 0, 0)), 2: ((0, -1, 0), (0, 1, 0))}.items():
        named = yao2023_magnetization(pattern, n, M)
        by_fraction = segments_magnetization(n, [MagnetizationSegment(back, M, fraction=0.5),
                                                 MagnetizationSegment(front, M, fraction=0.5)])
        by_count = segments_magnetization(n, [MagnetizationSegment(back, M, elements=n // 2),
                                              MagnetizationSegment(front, M, elements=n - n // 2)])
        # bit for bit: the same bytes, not merely close
        assert named.tobytes() == by_fraction.tobytes() == by_count.tobytes()


def test_the_papers_spec_written_as_segments_builds_the_same_robot():
    text = """
[robot]
length = 0.02
n_elements = 64
width = 0.008
thickness = 0.0008
density = 1860.0
youngs_modulus = 84500.0
shear_modulus = 57094.59459459459
[robot.magnetization]
kind = "segments"
magnitude = 61300.0
segments = [{fraction = 0.5, direction = [-1.0, 0.0, 0.0]}, {fraction = 0.5, direction = [1.0, 0.0, 0.0]}]
[robot.ground]
[robot.damping]
"""
    description = describe_robot(loads(text, "p1.toml"), "p1.toml")
    robot, paper = description.robot("accurate"), yao2023_robot(1, "accurate")
    assert robot.magnetization.tobytes() == paper.magnetization.tobytes()
    # complete tables: each segment carries its magnitude; they round-trip through TOML
    segments = description.tables["robot"]["magnetization"]["segments"]
    assert segments == [{"fraction": 0.5, "direction": [-1.0, 0.0, 0.0], "magnitude": 61300.0},
                        {"fraction": 0.5, "direction": [1.0, 0.0, 0.0], "magnitude": 61300.0}]
    again = describe_robot(loads(dumps(description.tables)), "again.toml")
    assert again.tables == description.tables


def test_three_segments_of_the_issue_robot():
    """+y / +x / -y thirds at 80 kA/m on 48 elements, each segment its own magnitude."""
    segments = [MagnetizationSegment((0, 1, 0), 80e3, fraction=1 / 3),
                MagnetizationSegment((2, 0, 0), 80e3, fraction=1 / 3),
                MagnetizationSegment((0, -1, 0), 40e3, fraction=1 / 3)]
    assert segment_element_counts(48, segments) == [16, 16, 16]
    m = segments_magnetization(48, segments)
    assert m.shape == (3, 48)
    assert np.array_equal(m[:, 0], [0, 80e3, 0]) and np.array_equal(m[:, 16], [80e3, 0, 0])
    assert np.array_equal(m[:, 47], [0, -40e3, 0]) and np.array_equal(m[:, 15], [0, 80e3, 0])
    # an element belongs to the segment holding its centre: 0.3 of 10 elements -> centres 0.05..0.25
    assert segment_element_counts(10, [MagnetizationSegment((1, 0, 0), 1.0, fraction=0.3),
                                       MagnetizationSegment((0, 1, 0), 1.0, fraction=0.7)]) == [3, 7]
    assert magnetization_array({"kind": "segments", "segments": [
        {"elements": 1, "direction": [0.0, 0.0, 1.0], "magnitude": 5.0},
        {"elements": 2, "direction": [0.0, 1.0, 0.0], "magnitude": 0.0}]}, 3).tolist() == [
        [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [5.0, 0.0, 0.0]]


LIBRARY_ERRORS = [
    ([MagnetizationSegment((1, 0, 0), 1.0, fraction=0.5),
      MagnetizationSegment((1, 0, 0), 1.0, fraction=0.4)], "fractions sum to 0.9, must sum to 1"),
    ([MagnetizationSegment((1, 0, 0), 1.0, elements=3),
      MagnetizationSegment((1, 0, 0), 1.0, elements=4)], "elements sum to 7 (3 + 4), the rod has "
                                                         "n_elements = 8"),
    ([MagnetizationSegment((0, 0, 0), 1.0, elements=8)], "segment 0: direction must be a finite "
                                                         "non-zero vector"),
    ([MagnetizationSegment((1, 0, 0), 1.0, elements=4),
      MagnetizationSegment((1, 0, 0), 1.0, fraction=0.5)], "all as elements or all as fraction"),
    ([MagnetizationSegment((1, 0, 0), 1.0)], "segment 0: give either elements"),
    ([MagnetizationSegment((1, 0, 0), 1.0, fraction=0.99),
      MagnetizationSegment((1, 0, 0), 1.0, fraction=0.01)], "segment 1: fraction 0.01 holds no "
                                                            "element centre"),
    ([MagnetizationSegment((1, 0, 0), -1.0, elements=8)], "segment 0: magnitude must be finite"),
    ([], "need at least one segment"),
]


@pytest.mark.parametrize(("segments", "message"), LIBRARY_ERRORS, ids=[e[1][:30] for e in LIBRARY_ERRORS])
def test_bad_segment_lists_are_named_errors(segments, message):
    with pytest.raises(ValueError) as err:
        segments_magnetization(8, segments)
    assert message in str(err.value), str(err.value)


SPEC = SMALL_BAND + """[robot.magnetization]
kind = "segments"
segments = [
    {elements = 4, direction = [0.0, 1.0, 0.0]},
    {elements = 4, direction = [0.0, -1.0, 0.0], magnitude = 1000.0},
]
"""

SPEC_ERRORS = [
    ("elements = 4, direction = [0.0, 1.0", "elements = 3, direction = [0.0, 1.0",
     "my.toml: [robot.magnetization] segments: elements sum to 7 (3 + 4), the rod has "
     "n_elements = 8"),
    ("elements = 4, direction = [0.0, 1.0", "fraction = 0.6, direction = [0.0, 1.0",
     "my.toml: [robot.magnetization] segments: give every segment's size the same way"),
    ("direction = [0.0, 1.0, 0.0]", "direction = [0.0, 0.0, 0.0]",
     "my.toml: [robot.magnetization.segments[0]] direction: must be a non-zero direction"),
    ("elements = 4, direction = [0.0, 1.0", "elements = 4, fraction = 0.5, direction = [0.0, 1.0",
     "my.toml: [robot.magnetization.segments[0]] elements: give either elements"),
    ("magnitude = 1000.0", "magnitude = -1.0", "my.toml: [robot.magnetization.segments[1]] "
     "magnitude: must be >= 0 (A/m)"),
    ("magnitude = 1000.0", "magnitude = 1000.0, colour = 1",
     "my.toml: [robot.magnetization.segments[1]] colour: unknown key"),
    ("elements = 4, direction = [0.0, 1.0", "elements = 4.5, direction = [0.0, 1.0",
     "my.toml: [robot.magnetization.segments[0]] elements: expected an integer"),
    ('segments = [\n    {', 'segments = 3\nx = [\n    {', "my.toml: [robot.magnetization] "
     "segments: expected a non-empty list of tables"),
    ('segments = [\n    {', 'segments = [3,\n    {', "my.toml: [robot.magnetization.segments[0]] must be a "
     "table"),
]


@pytest.mark.parametrize(("old", "new", "message"), SPEC_ERRORS, ids=[e[2][35:75] for e in SPEC_ERRORS])
def test_bad_segments_in_a_spec_name_the_file_the_segment_and_the_key(old, new, message):
    assert old in SPEC
    with pytest.raises(SpecError) as err:
        describe_robot(loads(SPEC.replace(old, new, 1), "my.toml"), "my.toml")
    assert message in str(err.value), str(err.value)


def test_fractions_not_summing_to_one_in_a_spec():
    text = SPEC.replace("elements = 4, direction = [0.0, 1.0", "fraction = 0.5, direction = [0.0, 1.0")
    text = text.replace("elements = 4, direction = [0.0, -1.0", "fraction = 0.25, direction = [0.0, -1.0")
    with pytest.raises(SpecError) as err:
        describe_robot(loads(text, "my.toml"), "my.toml")
    assert "my.toml: [robot.magnetization] segments: fractions sum to 0.75, must sum to 1" in str(err.value)


def test_the_spec_reference_example_parses_as_documented():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "specs.md").read_text()
    (block,) = [b for b in re.findall(r"```toml\n(.*?)```", text, flags=re.S) if "segments" in b]
    robot = SPEC.split("[robot.magnetization]")[0].replace("n_elements = 8", "n_elements = 48")
    m = describe_robot(loads(robot + block, "specs.md"), "specs.md").robot().magnetization
    expected = np.zeros((3, 48))
    expected[1, :16], expected[0, 16:32], expected[1, 32:] = 80e3, 80e3, -80e3
    assert np.array_equal(m, expected)
