"""The steering law of a tip-reach case as a controller that reads only the observation (what a
training's warm-up plays) acts as the law on the environment's own state does, for every form a
steered spec takes: a magnet arm with and without an insertion stage, coils with and without one."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import SPECS_DIR, load_case
from elastica_magnetic_rl.envs.catheter_env import make_catheter_env
from elastica_magnetic_rl.envs.steering_yardstick import SteeringYardstick
from elastica_magnetic_rl.envs.yardsticks import yardstick_controller
from elastica_magnetic_rl.shipping.tip_reach import held_out_targets, steering_controller


def _case(name: str, stage: bool):
    data = tomllib.loads((SPECS_DIR / f"{name}.toml").read_text())
    data["name"] = f"{name}-{'stage' if stage else 'fixed'}"
    if not stage:
        for key in ("insertion", "insertion_speed"):
            data["actuation"].pop(key, None)
        data["task"]["target_box"] = [[0.035, -0.012, -0.012], [0.045, 0.012, 0.012]]  # within reach
    return load_case(data)


@pytest.mark.parametrize("stage", [True, False], ids=["stage", "no-stage"])
@pytest.mark.parametrize("name", ["catheter-magnet-reach", "catheter-coils-reach"])
def test_the_observed_law_acts_as_the_law_on_the_environment(name, stage):
    case = _case(name, stage)
    assert bool(case.actuation.insertion) == stage
    n, steps = 3, 40
    env = make_catheter_env(case, n, "training")
    obs, _ = env.reset(seed=0, options={"target": held_out_targets(case, n)})
    act = steering_controller(env)
    observed = [yardstick_controller(case)() for _ in range(n)]
    assert all(isinstance(c, SteeringYardstick) for c in observed)
    assert (observed[0].obs_dim, observed[0].act_dim) == (env.single_observation_space.shape[0],
                                                          env.single_action_space.shape[0])
    for c in observed:
        c.reset()
    largest = 0.0
    for _ in range(steps):
        truth = act(env, obs)
        mine = np.stack([c.act(o) for c, o in zip(observed, obs, strict=True)])
        largest = max(largest, float(np.abs(mine - truth).max()))
        obs, _, terminated, truncated, _ = env.step(truth)
        assert not (terminated | truncated).any()
    # the float32 observation rounds lengths to ~1e-9 m: the commands agree to far below any
    # action's resolution; a wrong block, scale or base would differ by 1e-2 or more
    assert largest < 1e-4
    # and the commands moved: the law did steer (not two zero actions agreeing)
    assert float(np.abs(truth).max()) > 0.05


def test_its_state_round_trips_inside_an_episode():
    case = _case("catheter-magnet-reach", True)
    env = make_catheter_env(case, 1, "training")
    obs, _ = env.reset(seed=0, options={"target": held_out_targets(case, 1)})
    first, second = yardstick_controller(case)(), yardstick_controller(case)()
    first.reset()
    for _ in range(5):
        obs, *_ = env.step(first.act(obs[0])[None])
    second.set_state(first.state())
    assert np.array_equal(first.act(obs[0]), second.act(obs[0]))
    first.reset()
    assert first.state() is None


@pytest.mark.parametrize("name", ["catheter-magnet-reach", "catheter-coils-reach"])
def test_its_label_reads_the_observed_field_where_the_case_observes_one(name):
    """DAgger's teacher (``label``): where the observation shows the field at the tip (the coils'
    ``tip_field``) the label is a function of the observation alone, whatever the controller met
    before; elsewhere (the magnet arm) it is the law's own command, which remembers its direction."""
    case = load_case(name)
    env = make_catheter_env(case, 2, "training")
    obs, _ = env.reset(seed=0, options={"target": held_out_targets(case, 2)})
    act = steering_controller(env)
    for _ in range(15):  # the catheters under way: a field at the tip
        obs, *_ = env.step(act(env, obs))
    fresh, travelled = SteeringYardstick(case), SteeringYardstick(case)
    for o in (obs[1], obs[1], obs[0]):  # another history: the other catheter's observation
        travelled.act(o)
    first, second = fresh.label(obs[0]), travelled.label(obs[0])
    if "tip_field" in fresh.layout:
        np.testing.assert_array_equal(first, second)
        field = obs[0][fresh.layout["tip_field"]].astype(np.float64)
        assert fresh.law.field_direction @ (field / np.linalg.norm(field)) > 0.99  # turned from it
    else:
        assert float(np.abs(first - second).max()) > 1e-3  # each its own remembered direction
