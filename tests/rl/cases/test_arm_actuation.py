"""Cases steered by a magnet on an arm (issue 53): the ``[actuation] kind = "magnet-pose"`` table,
the ``tip-reach`` task's table, the pairs of task and actuation, the printed spec, and the
environment and training of such a case."""

from __future__ import annotations

import tomllib
import warnings

import numpy as np
import pytest
from elastica_magnetic_rl.cases.arm_actuation import MagnetArm
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.steered import NotFieldActuatedError
from elastica_magnetic_rl.cases.tasks import TipReachTask
from spec_texts import CATHETER_MAGNET_REACH

from elastica_magnetic.specfile import SpecError


def spec(**changes: object) -> dict:
    """The test catheter's tip-reach case as a dict, with ``changes`` ("table.key": value; None
    removes the key)."""
    data = tomllib.loads(CATHETER_MAGNET_REACH)
    data["name"] = "catheter"
    for dotted, value in changes.items():
        table, key = dotted.split(".")
        if value is None:
            data[table].pop(key, None)
        else:
            data[table][key] = value
    return data


def quiet_load(data):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_case(data)


def test_the_case_reads_and_round_trips():
    case = quiet_load(spec())
    assert isinstance(case.actuation, MagnetArm) and isinstance(case.task, TipReachTask)
    assert case.actuation.arm_settings()["workspace"] == [[-0.1, -0.1, -0.1], [0.15, 0.1, 0.1]]
    assert case.task.target_box == ((0.04, 0.0, -0.01), (0.045, 0.015, 0.01))
    assert not case.field_actuated and case.obs_dim == 3 * 11 + 12
    assert case.evaluation_duration == 2.0 and not case.has_yardstick
    assert quiet_load({**case.to_dict(), "name": "catheter"}).to_dict() == case.to_dict()
    text = case.toml()
    assert "target_box = [[0.04, 0.0, -0.01], [0.045, 0.015, 0.01]]  # m, [[xmin, ymin, zmin]" in text
    assert "workspace = [[-0.1, -0.1, -0.1], [0.15, 0.1, 0.1]]  # m" in text
    with pytest.raises(NotFieldActuatedError, match=r"magnet-pose.*it asks the case for its field_limit"):
        _ = case.field_limit


@pytest.mark.parametrize(("changes", "message"), [
    ({"actuation.moment": -1.0}, r"\[actuation\] moment.*> 0"),
    ({"actuation.position": [90.0, 0.0, 0.0]}, r"position.*mm written as m"),
    ({"actuation.workspace": [[-0.1, -0.1, -0.1], [0.15, 0.1]]}, r"workspace.*\[\[xmin"),
    ({"actuation.workspace": [[0.1, -0.1, -0.1], [0.05, 0.1, 0.1]]}, r"workspace.*below its max"),
    ({"actuation.position": [0.2, 0.0, 0.0]}, r"outside the workspace"),
    ({"actuation.position": [0.03, 0.005, 0.0]}, r"5 mm from the straight rod.*min_clearance"),
    ({"actuation.direction": [0.0, 0.0, 0.0]}, r"direction.*non-zero"),
    ({"actuation.max_speed": 100.0}, r"max_speed: 100 m/s is beyond any arm or stage \(5 m/s\)"),
    ({"actuation.max_turn_rate": 90.0}, r"max_turn_rate: 90 rad/s is beyond any arm \(20 rad/s\)"),
    ({"actuation.field_limit": 0.004}, r"\[actuation\] field_limit: unknown key"),
    ({"task.target_box": [[40.0, 0.0, 0.0], [48.0, 1.0, 1.0]]}, r"target_box.*wholly beyond.*mm written"),
    ({"task.target_box": [[0.05, 0.0, 0.0], [0.04, 0.01, 0.01]]}, r"target_box.*at most its max"),
    ({"task.kind": "crawl", "task.target_box": None, "task.tolerance": None}, r"crawler's task.*tip-reach"),
])
def test_bad_values_are_refused_by_name(changes, message):
    with pytest.raises(SpecError, match=message):
        quiet_load(spec(**changes))


def test_a_tip_reach_task_needs_the_arm_and_a_box_partly_out_of_reach_is_warned():
    field = {"kind": "field", "field_limit": 0.004}
    data = spec()
    data["actuation"] = field
    with pytest.raises(SpecError, match=r"tip-reach.*set \[actuation\] kind = \"magnet-pose\""):
        quiet_load(data)
    with pytest.warns(UserWarning, match=r"target_box.*beyond the rod's reach"):
        load_case(spec(**{"task.target_box": [[0.04, 0.0, 0.0], [0.06, 0.01, 0.01]]}))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_case(spec(**{"task.target_box": [[0.04, 0.0, 0.0], [0.045, 0.01, 0.01]]}))


def test_the_case_makes_the_catheter_environment():
    from elastica_magnetic_rl.envs.vector_env import make_vector_env

    case = quiet_load(spec())
    env = make_vector_env(case, 2, duration=0.5)
    obs, info = env.reset(seed=0)
    assert obs.shape == (2, case.obs_dim) and env.max_episode_steps == 50
    low, high = np.asarray(case.task.target_box)
    assert np.all((info["target_m"] >= low) & (info["target_m"] <= high))
    with pytest.raises(ValueError, match="train on their nominal robot"):
        make_vector_env(case, 2, randomize=["dummy"])


def test_msr_train_runs_a_catheter_case(tmp_path, capfd):
    from elastica_magnetic.cli import main as msr

    path = tmp_path / "catheter.toml"
    # a box whose far corner (49, 15, 10) mm is 52 mm from the base: beyond the 50 mm reach
    path.write_text(CATHETER_MAGNET_REACH.replace("kind = \"tip-reach\"", "kind = \"tip-reach\"\n"
                                                  "episode_duration = 0.2").replace(
        "episode_duration = 2.0\n", "").replace("[0.045, 0.015, 0.01]]", "[0.049, 0.015, 0.01]]"))
    code = msr(["train", "--case", str(path), "--steps", "40", "--seeds", "1",
                "--set", "learning_starts=20", "--set", "batch_size=16", "--set", "eval_every=0",
                "--stop-when", "none", "--out", str(tmp_path / "runs"), "--no-progress"])
    assert code == 0
    run = tmp_path / "runs" / "catheter" / "seed0"
    assert (run / "checkpoint.pt").is_file() and (run / "episodes.csv").is_file()
    out, err = capfd.readouterr()
    assert err.count("lies beyond the rod's reach") == 1  # the command's, not again by its worker
    assert "to targets drawn in the task's target_box" in out and "initial fields" not in out
    assert "held-out targets" in out and "export-seeds" not in out


def test_case_show_and_check_describe_the_arm(tmp_path, capsys):
    from elastica_magnetic.cli import main as msr

    path = tmp_path / "catheter.toml"
    path.write_text(CATHETER_MAGNET_REACH)
    capsys.readouterr()
    assert msr(["case", "show", str(path)]) == 0
    out = capsys.readouterr().out
    assert "a 1 A m^2 magnet on an arm, starting at (90, 0, 0) mm" in out
    assert "3.13 mT at the straight tip at the start" in out  # 2 x 1e-7 x 1 A m^2 / (40 mm)^3
    assert "the tip within 1.0 mm of a target in its box in 2 s" in out and "yardstick" not in out
    assert msr(["case", "show", str(path), "--toml"]) == 0
    assert "target_box = [[0.04, 0.0, -0.01], [0.045, 0.015, 0.01]]" in capsys.readouterr().out
    assert msr(["case", "check", str(path)]) == 0
    out = capsys.readouterr().out
    assert "field        3.13 mT (the magnet's at the straight tip at its start pose): magnetic" in out
    assert "field limit" not in out  # a magnet on an arm has no coils' limit


def test_an_insertion_stage_adds_an_action_and_an_observation():
    case = quiet_load(spec(**{"actuation.insertion": [-0.01, 0.01], "actuation.insertion_speed": 0.02}))
    arm = case.actuation
    assert arm.insertion == (-0.01, 0.01) and arm.action_size == 6
    assert case.obs_dim == 3 * 11 + 12 + 1
    assert quiet_load(case.to_dict()).to_dict() == case.to_dict()
    with pytest.raises(SpecError, match=r"insertion: \[0.01, 0.02\] m must hold 0"):
        quiet_load(spec(**{"actuation.insertion": [0.01, 0.02]}))
    with pytest.raises(SpecError, match=r"insertion_speed: is for an insertion stage"):
        quiet_load(spec(**{"actuation.insertion_speed": 0.02}))
    with pytest.raises(SpecError, match=r"insertion: .*mm written as m"):
        quiet_load(spec(**{"actuation.insertion": [-10.0, 20.0]}))


def test_the_insertion_stage_pushes_the_base_in_the_environment():
    from elastica_magnetic_rl.envs.vector_env import make_vector_env

    case = quiet_load(spec(**{"actuation.insertion": [-0.01, 0.01], "actuation.insertion_speed": 0.02}))
    env = make_vector_env(case, 2, duration=1.0)
    obs, _ = env.reset(seed=0)
    assert env.action_space.shape == (2, 6) and obs.shape == (2, case.obs_dim)
    push = np.zeros((2, 6))
    push[:, 5] = [1.0, -1.0]
    for _ in range(10):
        obs, *_ = env.step(push)
    assert env.insertion(0) == pytest.approx(0.002) and env.insertion(1) == pytest.approx(-0.002)
    assert env.robots.rod(0).position_collection[0, 0] == pytest.approx(0.002, abs=1e-12)
    layout = env.layout
    assert obs[0, layout["insertion"]][0] == pytest.approx(0.2)  # 100 per m
    state = env.get_state()
    actions = np.random.default_rng(1).uniform(-1, 1, (3, 2, 6))
    first = [env.step(a)[0] for a in actions]
    other = make_vector_env(case, 2, duration=1.0)
    other.set_state(state)
    assert all(np.array_equal(a, other.step(b)[0]) for a, b in zip(first, actions, strict=True))
