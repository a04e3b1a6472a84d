"""The tutorial's code runs as written (with fewer time steps)."""

import re
from pathlib import Path

import numpy as np

TUTORIAL = Path(__file__).resolve().parents[1] / "docs" / "tutorial.md"


def test_tutorial_code_runs():
    blocks = re.findall(r"```python\n(.*?)```", TUTORIAL.read_text(), flags=re.S)
    assert len(blocks) >= 6
    namespace: dict = {}
    for block in blocks:
        code = block.replace("range(125_000)", "range(500)").replace(".advance(1.0)", ".advance(0.01)")
        exec(compile(code, str(TUTORIAL), "exec"), namespace)
    rod = namespace["rod"]
    assert np.all(np.isfinite(rod.position_collection))
    assert abs(rod.position_collection[1]).max() > 0  # the field did something
    assert namespace["simulation"].time > 0


def test_training_tutorial_environment_snippet():
    text = (TUTORIAL.parent / "training.md").read_text()
    (block,) = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    namespace: dict = {}
    exec(compile(block, "training.md", "exec"), namespace)
    assert namespace["obs"].shape == (260,)
    assert not namespace["terminated"] and not namespace["truncated"]


def test_spatial_fields_page_code_runs():
    page = TUTORIAL.parent / "spatial_fields.md"
    (block,) = re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)
    namespace: dict = {}
    exec(compile(block.replace("range(100_000)", "range(300)"), str(page), "exec"), namespace)
    assert namespace["B"].shape == (3, 1) and namespace["G"].shape == (3, 3, 1)
    rod = namespace["rod"]
    assert np.all(np.isfinite(rod.position_collection))
    assert abs(rod.position_collection[1, -1]) > 0  # the magnet did something
