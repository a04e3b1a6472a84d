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


def _with_body(**magnet: object) -> dict:
    data = spec()
    data["actuation"]["magnet"] = {"shape": "cuboid", "dimension": [0.01, 0.01, 0.01], **magnet}
    return data


#: The forms a magnet's body takes in a spec: a cuboid with the map's defaults, a cylinder on a case
#: with an insertion stage, a map's size and spacing written out.
BODY_FORMS = {
    "cuboid": ({}, {}, "cuboid 10 x 10 x 10 mm"),
    "cylinder-insertion": ({"shape": "cylinder", "dimension": [0.012, 0.00884]},
                           {"insertion": [-0.01, 0.01], "insertion_speed": 0.01}, "cylinder 12 x 8.84 mm"),
    "written-map": ({"map_half_width": 0.3, "map_spacing": 0.006}, {}, "mapped +-300 mm at 6 mm"),
}


@pytest.mark.parametrize("form", BODY_FORMS)
def test_a_magnet_with_a_body_steers_through_its_map(form):
    """``[actuation.magnet]``: the arm's magnet is a body, its field a map in its own frame scaled
    to the arm's moment (J = mu0 m / V: 1.26 T for 1 A m^2 in 1 cm^3); by default the map holds the
    rod wherever the arm goes (the farthest workspace corner from the base over the stage's travel,
    plus the rod), its spacing coarsened to 101 nodes a side but at most half min_clearance; the case
    round-trips and its
    environment steps. At the start pose the field at the straight tip, 40 mm from the magnet, is
    the body's (Magpylib's, within the map's error at its spacing)."""
    from elastica_magnetic_rl.envs.vector_env import make_vector_env

    from elastica_magnetic import CuboidMagnetField, CylinderMagnetField

    magnet, actuation, words = BODY_FORMS[form]
    data = _with_body(**magnet)
    data["actuation"].update(actuation)
    case = quiet_load(data)
    body = case.actuation.magnet
    base = 0.01 if "insertion" in actuation else 0.0
    needed = np.linalg.norm([0.15 + base, 0.1, 0.1]) + 0.05
    if "map_half_width" not in magnet:
        assert body.map_half_width == pytest.approx(needed, rel=1e-12)
        # 101 nodes a side, finer down to half min_clearance (10 mm)
        assert body.map_spacing == pytest.approx(min(2 * body.map_half_width / 100, 0.005), rel=1e-12)
    assert body.polarization(1.0) == pytest.approx(4e-7 * np.pi / body.volume, rel=1e-12)
    assert words in case.actuation.describe(0.05)
    assert quiet_load({**case.to_dict(), "name": "catheter"}).to_dict() == case.to_dict()
    assert "[actuation.magnet]" in case.toml()
    arm = case.actuation.actuator()
    assert arm.field_map is body.field_map() and case.actuation.actuator().field_map is arm.field_map
    tip = np.array([[0.05], [0.0], [0.0]])
    pose = {"position": arm.position_at(0.0), "axis": arm.direction_at(0.0)}
    polarization = [0.0, 0.0, body.polarization(1.0)]
    exact = (CuboidMagnetField(list(body.dimension), polarization, **pose) if body.shape == "cuboid" else
             CylinderMagnetField(*body.dimension, polarization, **pose)).at(tip, 0.0)
    # the map's error 30-50 mm from a magnet: 2.5 % at 4 mm spacing (docs/spatial_fields.md), ~ spacing^2
    error = 0.03 * (body.map_spacing / 0.004) ** 2
    np.testing.assert_allclose(arm.source.at(tip, 0.0), exact, rtol=error, atol=1e-3 * np.abs(exact).max())
    env = make_vector_env(case, 2, duration=0.05)
    env.reset(seed=0)
    obs, *_ = env.step(np.full(env.action_space.shape, 0.5, dtype=np.float32))
    assert np.all(np.isfinite(obs))


@pytest.mark.parametrize(("magnet", "moment", "message"), [
    ({"dimension": [10.0, 10.0, 10.0]}, 1.0, r"\[actuation.magnet\] dimension.*mm written as m"),
    ({"dimension": [0.005, 0.005, 0.005]}, 1.0, r"\[actuation\] moment.*J = mu0 m / V = 10.1 T, beyond any"),
    ({"dimension": [0.02, 0.02, 0.02]}, 1.0, r"min_clearance: 10 mm is less than half the magnet's diagonal"),
    ({"shape": "sphere"}, 1.0, r"\[actuation.magnet\] shape.*cuboid, cylinder"),
    ({"shape": "cylinder"}, 1.0, r"\[actuation.magnet\] dimension.*\[diameter, height\]"),
    ({"map_half_width": 0.1}, 1.0, r"map_half_width: 0.1 m does not hold the rod.*0.2562 m at least"),
    ({"map_spacing": 0.001}, 1.0, r"map_spacing: 0.001 m .* more than 2000000: 0.0041 m or coarser"),
    ({"remanence": 1.3}, 1.0, r"\[actuation.magnet\] remanence: unknown key"),
])
def test_a_magnet_body_that_cannot_be_is_refused_by_name(magnet, moment, message):
    data = _with_body(**magnet)
    data["actuation"]["moment"] = moment
    with pytest.raises(SpecError, match=message):
        quiet_load(data)


def test_a_body_far_larger_than_its_moment_is_warned():
    data = _with_body(dimension=[0.05, 0.05, 0.05])
    data["actuation"]["min_clearance"] = 0.05
    data["actuation"]["position"] = [0.11, 0.0, 0.0]
    with pytest.warns(UserWarning, match=r"dimension.*a body far larger than its moment"):
        load_case(data)
