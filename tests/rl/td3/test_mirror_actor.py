"""The mirror-symmetric steering actor (``actor_mirror``, rl/td3/steering_inputs.py): its command for
a state's mirror image (z -> -z) is its command's mirror image, bit for bit; a symmetric state gets
no left command, so a residual policy on a symmetric walk keeps the robot in its plane; the stacked
learner and a reloaded actor are the same actor; a case whose robot is not its own mirror image is
refused before any work."""

from __future__ import annotations

import re

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.cases.case import SPECS_DIR, load_case
from elastica_magnetic_rl.envs.env import MagneticCrawlerEnv
from elastica_magnetic_rl.envs.residual import ResidualController, residual_base
from elastica_magnetic_rl.td3.algorithm import TD3
from elastica_magnetic_rl.td3.config import TD3Config
from elastica_magnetic_rl.td3.networks import Actor, actor_from_state, networks_from_state
from elastica_magnetic_rl.td3.steering_inputs import steering_start

torch.set_num_threads(1)

CASE = "m1-4mT-goto"


@pytest.fixture(scope="module")
def walk_obs(walked):
    """The observations of the shared walk toward a target ahead and to the left (conftest.py):
    none of them is its own mirror image. Its layout and the observations ``(N, obs_dim)``."""
    env, _, seen = walked
    return env.layout, np.stack([obs for obs, _ in seen]).astype(np.float32)


def mirrored(obs: np.ndarray, layout: dict[str, slice]) -> np.ndarray:
    """Observations ``(N, obs_dim)`` of the mirror image z -> -z of the scene: the field's z, the
    heading's sine and the target's left offset change sign; the in-plane blocks do not."""
    out = np.array(obs, copy=True)
    for index in (layout["field_z"].start, layout["heading"].start + 1, layout["target_offset"].start + 1):
        out[:, index] = -out[:, index]
    return out


def mirror_actor(obs_dim: int, layout: dict[str, slice], seed: int = 0) -> Actor:
    torch.manual_seed(seed)
    actor = Actor(obs_dim, 3, (32, 32), steering_start(layout), mirror=True)
    with torch.no_grad():  # outputs of a useful size, so that the left command is not 0 by chance
        actor.net[-1].weight.mul_(5.0)
    return actor.eval()


def test_the_mirror_image_of_a_state_gets_the_mirror_image_of_the_command(walk_obs):
    layout, obs = walk_obs
    actor = mirror_actor(obs.shape[1], layout)
    with torch.no_grad():
        command = actor(torch.as_tensor(obs)).numpy()
        image = actor(torch.as_tensor(mirrored(obs, layout))).numpy()
    assert np.all(np.abs(command[:, 2]) > 1e-4), "the walk's states are not symmetric"
    np.testing.assert_array_equal(image, command * np.array([1.0, 1.0, -1.0], dtype=np.float32))
    # the same network without the symmetry is not equivariant: the test can tell the two apart
    plain = Actor(obs.shape[1], 3, (32, 32), steering_start(layout))
    plain.net.load_state_dict(actor.net.state_dict())
    with torch.no_grad():
        apart = plain(torch.as_tensor(mirrored(obs, layout))).numpy() - \
            plain(torch.as_tensor(obs)).numpy() * np.array([1.0, 1.0, -1.0], dtype=np.float32)
    assert np.max(np.abs(apart)) > 1e-3


def test_a_symmetric_walk_stays_in_its_plane_under_a_mirror_symmetric_correction():
    """At 10 mT the yardstick walks toward a target straight ahead with no z field, and every z of
    the robot stays 0 (the 4 mT one turns in place, with a z field, even then); corrected by a
    mirror-symmetric actor it still does, while the same actor without the symmetry tips the robot
    out of its plane at once. Exactly 0 until the band, tumbling end over end, first faces
    backwards (step 94 at the case's 0.15 s a turn): the observation's heading is then (cos, sin) of
    pi, whose sine is 1.2e-16, not 0, so the state is its mirror image only to rounding, and so is
    the command (B_z about 1e-20 T, z about 1e-21 m: 15 orders under the unsymmetric actor's)."""
    case = load_case("m1-10mT-goto")

    def walk(mirror: bool) -> tuple[float, float, int]:  # largest |B_z| (T), |z| (m), exact steps
        env = MagneticCrawlerEnv(case=case, physics="training", initial_field="zero", duration=30.0)
        obs, _ = env.reset(seed=0, options={"target": (0.1, 0.0)})
        actor = mirror_actor(len(obs), env.layout, seed=2)
        if not mirror:
            plain = Actor(len(obs), 3, (32, 32), steering_start(env.layout))
            plain.net.load_state_dict(actor.net.state_dict())
            actor = plain.eval()

        def correction(rows: np.ndarray) -> np.ndarray:
            with torch.no_grad():
                return actor(torch.as_tensor(rows)).numpy()

        policy = ResidualController(correction, residual_base(case), 0.5)
        largest_bz = largest_z = 0.0
        exact_steps = None  # how many steps kept B_z and every z exactly 0
        for step in range(100):
            obs, *_ = env.step(policy.act(obs))
            largest_bz = max(largest_bz, abs(float(env.field.value[2])))
            largest_z = max(largest_z, float(np.max(np.abs(env.simulation.rod.position_collection[2]))))
            if exact_steps is None and (largest_bz or largest_z):
                exact_steps = step
        return largest_bz, largest_z, 100 if exact_steps is None else exact_steps

    bz, z, exact_steps = walk(mirror=True)
    assert exact_steps >= 90 and bz < 1e-18 and z < 1e-18  # T, m: rounding (the docstring)
    tipped_bz, tipped_z, tipped_exact = walk(mirror=False)
    assert tipped_exact < 10 and tipped_bz > 1e-5 and tipped_z > 1e-9


def test_the_stacked_learner_and_a_reloaded_actor_are_the_same_mirror_symmetric_actor(walk_obs):
    layout, obs = walk_obs
    configs = [TD3Config(seed=s, hidden_sizes=(32, 32), batch_size=64, actor_input="steering",
                         actor_mirror=True) for s in (0, 1)]
    learner = TD3(obs.shape[1], 3, -np.ones(3), np.ones(3), configs)
    acted = learner.select_actions(np.stack([obs[:20], obs[20:40]]), explore=False)
    for k in (0, 1):
        state = learner.actor_state(k)
        assert "steering_mirror" in state
        loaded, _ = networks_from_state(obs.shape[1], 3, (32, 32), state, None)
        assert loaded.mirror
        with torch.no_grad():
            alone = loaded(torch.as_tensor(obs[20 * k: 20 * k + 20])).numpy()
        np.testing.assert_allclose(acted[k], alone, atol=1e-6)
    plain = Actor(obs.shape[1], 3, (32, 32), steering_start(layout)).state_dict()  # stays unmirrored
    assert not actor_from_state(obs.shape[1], 3, (32, 32), plain).mirror


def test_a_mirror_symmetric_actor_needs_a_steering_actor():
    with pytest.raises(ValueError, match="actor_mirror .* needs actor_input = 'steering'"):
        TD3Config(actor_mirror=True)
    assert TD3Config.parse_setting("actor_mirror", "true") is True
    with pytest.raises(ValueError, match="steering_start"):
        Actor(10, 3, (8,), None, mirror=True)


def test_a_robot_that_is_not_its_own_mirror_image_is_refused_before_any_work(tmp_path):
    from elastica_magnetic_rl.sweep.training import train_cases

    spec = (SPECS_DIR / f"{CASE}.toml").read_text()
    tilted = re.sub(r"\[robot\.magnetization\]\n(?:[^\[\n][^\n]*\n|\n)*",
                    "[robot.magnetization]\nkind = \"segments\"\nmagnitude = 61300.0\nsegments = [\n"
                    "    {fraction = 0.5, direction = [1.0, 0.0, 0.5]},\n"
                    "    {fraction = 0.5, direction = [0.0, 1.0, 0.0]},\n]\n\n", spec, count=1)
    assert tilted != spec
    path = tmp_path / "tilted-goto.toml"
    path.write_text(tilted)
    out = tmp_path / "runs"
    with pytest.raises(ValueError, match=r"magnetization has a z component \(up to 2\.74\d*e\+04 A/m"):
        train_cases([str(path)], seeds=1, steps=50, out=out, progress=False,
                    config_overrides={"actor_mirror": True, "learning_starts": 10})
    assert not out.exists() or not any(out.rglob("checkpoint.pt"))
    # the shipped goto case's robot is its own mirror image: the same settings pass this check
    from elastica_magnetic_rl.sweep.sweep_plan import _check_mirror_image

    _check_mirror_image(CASE, load_case(CASE))



def test_a_mirror_symmetric_policy_s_card_says_so():
    from elastica_magnetic_rl.shipping.model_card import _steering_line

    steering = {"actor_input": "steering", "residual": 0.5}
    assert "mirror-symmetric" in _steering_line({"architecture": {**steering, "actor_mirror": True}})[0]
    assert "mirror" not in _steering_line({"architecture": steering})[0]


def test_a_mirror_symmetric_actor_exports_as_it_acts(walk_obs):
    """The exported module (``msr policy export`` traces the scaled actor) keeps the symmetry."""
    from elastica_magnetic_rl.td3.networks import ScaledPolicy

    layout, obs = walk_obs
    actor = mirror_actor(obs.shape[1], layout)
    policy = ScaledPolicy(actor, -np.full(3, 3e-4), np.full(3, 3e-4)).eval()
    traced = torch.jit.trace(policy, torch.as_tensor(obs[:1]), check_trace=True)
    with torch.no_grad():
        np.testing.assert_allclose(traced(torch.as_tensor(obs)).numpy(), policy(torch.as_tensor(obs)).numpy(),
                                   rtol=0, atol=1e-12)
        image = traced(torch.as_tensor(mirrored(obs, layout))).numpy()
        direct = policy(torch.as_tensor(obs)).numpy()
    np.testing.assert_allclose(image, direct * np.array([1.0, 1.0, -1.0]), rtol=0, atol=1e-12)
