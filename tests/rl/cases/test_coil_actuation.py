"""Cases steered by the currents of fixed coils (issue 53): the ``[actuation] kind =
"coil-currents"`` table and its refusals, the shipped case, its environment (spaces, state), and
the coils' yardstick."""

from __future__ import annotations

import copy
import warnings

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import load_case
from elastica_magnetic_rl.cases.coil_actuation import CoilArray
from elastica_magnetic_rl.cases.steered import NotFieldActuatedError
from elastica_magnetic_rl.envs.vector_env import make_vector_env

from elastica_magnetic import CoilCurrents
from elastica_magnetic.specfile import SpecError


@pytest.fixture(scope="module")
def shipped():
    return load_case("catheter-coils-reach")


def spec(shipped, **changes):
    """The shipped coil case as a dict, with ``changes`` (``"actuation.key"`` or
    ``"coil0.key"``: value; None removes the key)."""
    data = copy.deepcopy(shipped.to_dict())
    data["name"] = "coils"
    for dotted, value in changes.items():
        table, key = dotted.split(".")
        target = data["actuation"]["coils"][0] if table == "coil0" else data[table]
        if value is None:
            target.pop(key, None)
        else:
            target[key] = value
    return data


def quiet_load(data):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_case(data)


def test_the_shipped_case_reads_round_trips_and_names_what_it_lacks(shipped):
    a = shipped.actuation
    assert isinstance(a, CoilArray) and len(a.coils) == 8 and a.current_limit == 8.0
    assert a.action_size == 9 and not shipped.field_actuated  # 8 currents and the stage
    # node positions, tip velocity, currents, tip field, stage, target
    assert shipped.obs_dim == 3 * 11 + 3 + 8 + 3 + 1 + 3
    renamed = {**shipped.to_dict(), "name": "coils"}
    assert quiet_load(renamed).to_dict() == renamed
    # 2 mT per coil at the workspace's centre at 8 A (mu0 N I a^2 / (2 (a^2 + d^2)^1.5)): the eight
    # together, on the straight tip 5 mm from that centre, give up to some 9 mT
    assert 8e-3 < a.field_at_tip(0.05) < 10e-3
    text = shipped.toml()
    assert "[[actuation.coils]]" in text and "kind = \"coil-currents\"" in text
    with pytest.raises(NotFieldActuatedError, match=r"coil-currents.*asks the case for its field_limit"):
        _ = shipped.field_limit


@pytest.mark.parametrize(("changes", "message"), [
    ({"coil0.radius": 40.0}, r"coils\[0\]\] radius: must be <= 2 \(m\)"),
    ({"coil0.centre": [-24.3, -69.3, -69.3]}, r"coils\[0\]\] centre.*mm written as m"),
    ({"coil0.centre": [0.02, 0.0, 0.03], "coil0.radius": 0.03}, r"coils\[0\].*winding.*within the rod's"),
    ({"coil0.axis": [0.0, 0.0, 0.0]}, r"axis: must be a non-zero direction"),
    ({"coil0.turns": 0}, r"turns: must be >= 1"),
    ({"coil0.windings": 3}, r"coils\[0\]\] windings: unknown key"),
    ({"actuation.current_limit": 8000.0}, r"current_limit: must be <= 1000 \(A\)"),
    ({"actuation.max_slew": 0.001}, r"max_slew.*8000 s to reach the current limit.*A/ms written as A/s"),
    ({"actuation.coils": []}, r"coils: expected a non-empty list"),
    ({"actuation.insertion": None}, r"insertion_speed: is for an insertion stage"),
])
def test_bad_coil_values_are_refused_by_name(shipped, changes, message):
    with pytest.raises(SpecError, match=message):
        quiet_load(spec(shipped, **changes))


def test_the_coil_environment_steps_and_restores_its_state(shipped):
    env = make_vector_env(shipped, 2)
    assert env.single_action_space.shape == (9,) and env.single_observation_space.shape == (51,)
    assert isinstance(env.actuators[0], CoilCurrents) and env.min_clearance is None
    obs, info = env.reset(seed=3)
    currents = env.layout["coil_currents"]
    assert np.all(obs[:, currents] == 0.0)  # every episode from zero currents
    actions = np.zeros((2, 9), dtype=np.float32)
    actions[:, 0] = 1.0
    obs, *_ = env.step(actions)
    # 1000 A/s for 0.01 s: 10 A asked, the limit 8 A reached within the step; observed over the limit
    np.testing.assert_allclose(obs[:, currents][:, 0], 1.0)
    # the field at the tip: the one the rod's tip feels from the coils (their summed source), 100 per T
    for i in range(2):
        tip = env.tip(i)
        felt = env.actuators[i].source.at(tip.reshape(3, 1), env.robots.robot_time(i))[:, 0]
        assert np.linalg.norm(felt) > 1e-4  # 8 A in coil 0: a field of ~mT at the tip
        np.testing.assert_allclose(obs[i, env.layout["tip_field"]], 100.0 * felt, rtol=1e-6, atol=1e-9)
    state = env.get_state()
    rng = np.random.default_rng(0)
    plan = rng.uniform(-1, 1, (5, 2, 9)).astype(np.float32)
    first = [env.step(a)[0] for a in plan]
    env.set_state(state)
    again = [env.step(a)[0] for a in plan]
    np.testing.assert_array_equal(np.stack(first), np.stack(again))
