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
    # the first block (the second, the actuators', runs in tests/test_actuation.py)
    block = re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)[0]
    namespace: dict = {}
    exec(compile(block.replace("range(100_000)", "range(300)"), str(page), "exec"), namespace)
    assert namespace["B"].shape == (3, 1) and namespace["G"].shape == (3, 3, 1)
    rod = namespace["rod"]
    assert np.all(np.isfinite(rod.position_collection))
    assert abs(rod.position_collection[1, -1]) > 0  # the magnet did something


def test_spatial_fields_page_batched_arms_run():
    """The page's third block (many catheters, each with its arm), on the tests' catheter."""
    from spec_texts import CATHETER

    from elastica_magnetic.spec_format import loads
    from elastica_magnetic.specfile import describe_robot

    page = TUTORIAL.parent / "spatial_fields.md"
    block = re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S)[2]
    namespace: dict = {"catheter_spec": describe_robot(loads(CATHETER, "c.toml"), "c.toml").robot("training")}
    exec(compile(block, str(page), "exec"), namespace)
    robots = namespace["robots"]
    assert robots.time == 0.01 and robots.clamp
    assert np.all(np.isfinite(robots.rod(3).position_collection))


def test_the_own_robot_example_spec_is_the_pages_robot():
    """docs/examples/band20.toml, the robot docs/own_robot.md was walked with, is the robot the
    page describes: its magnetization table is the page's ``segments`` example, and it gives the
    element ranges the page's ``msr case check`` output shows."""
    import tomllib

    from elastica_magnetic_rl.cases.case import load_case

    from elastica_magnetic.specfile import magnetization_array

    spec = TUTORIAL.parent / "examples" / "band20.toml"
    page = (TUTORIAL.parent / "own_robot.md").read_text()
    case = load_case(spec)
    assert case.field_limit == 0.006 and case.yardstick.distance_10s == 0.0
    table = case.robot.tables["robot"]["magnetization"]
    (block,) = [b for b in re.findall(r"```toml\n(.*?)```", page, flags=re.S) if "segments" in b]
    m = magnetization_array(table, case.robot.n_elements)
    on_page = load_case({**case.to_dict(), "robot": {
        **case.to_dict()["robot"], "magnetization": tomllib.loads(block)["robot"]["magnetization"]}})
    assert np.array_equal(magnetization_array(on_page.robot.tables["robot"]["magnetization"], 32), m)
    assert m.shape == (3, 32)
    expected = [(0, 11, (0, 80e3, 0)), (11, 21, (80e3, 0, 0)), (21, 32, (0, -80e3, 0))]
    for start, stop, value in expected:
        assert np.array_equal(m[:, start:stop], np.tile(np.array(value)[:, None], stop - start))
        assert f"elements {start}-{stop - 1}: ({value[0]:g}, {value[1]:g}, {value[2]:g}) A/m" in page


def test_steering_page_snippet_runs_and_its_numbers_hold():
    """docs/steering_3d.md: the goto snippet runs; the sideways numbers it quotes are measured."""
    import json
    import subprocess
    import sys
    import tempfile

    text = (TUTORIAL.parent / "steering_3d.md").read_text()
    (block,) = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    namespace: dict = {}
    exec(compile(block, "steering_3d.md", "exec"), namespace)
    assert namespace["obs"].shape == (4 * 64 + 4 + 6,)  # heading, target offset, clock
    assert "-23.2 mm" in text
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run([sys.executable, "-m", "elastica_magnetic.cli", "field", "simulate",
                               "--physics", "training", "--duration", "3", "--heading", "1.5708",
                               "--out", f"{tmp}/side", "--no-progress", "--json"],
                              capture_output=True, text=True, check=True)
    assert round(1e3 * json.loads(done.stdout)["mid_dz_m"], 1) == -23.2


def test_steering_page_yardstick_times_are_measured():
    """docs/steering_3d.md quotes the 4 mT steering yardstick's time to a target abeam and to one
    straight ahead (training physics), at one turn a second and at the case's 2 s a turn: all
    measured here."""
    from elastica_magnetic_rl.envs.yardsticks import SteeringFieldPolicy
    from elastica_magnetic_rl.shipping.goto import evaluate_ring

    text = (TUTORIAL.parent / "steering_3d.md").read_text()
    times = {}
    for period in (1.0, None):  # None: the case's own, 2 s
        policy = SteeringFieldPolicy("m1-4mT-goto", period)
        (abeam,) = evaluate_ring(policy, 3.0, "training", targets=[(0.0, 0.015)])
        (ahead,) = evaluate_ring(policy, 30.0, "training", targets=[(0.015, 0.0)])  # as on the ring
        assert abeam["success"] and ahead["success"]
        times[policy.period] = (abeam["time_to_target_s"], ahead["time_to_target_s"])
    (abeam_1, ahead_1), (abeam_2, ahead_2) = times[1.0], times[2.0]
    assert f"{abeam_1:.2f} s abeam, {ahead_1:.1f} s straight ahead" in text
    assert f"walks abeam slower ({abeam_2:.2f} s against {abeam_1:.2f} s)" in text
    assert f"(straight ahead {ahead_2:.1f} s against {ahead_1:.1f} s)" in text
