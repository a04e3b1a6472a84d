"""``msr train`` of a crawl case whose ``[yardstick]`` records its rotating field, started from it
(``yardstick_warmup``): the spec keys, the controller the training takes, and a smoke run whose
warm-up is the rotating field."""

from __future__ import annotations

import numpy as np
import pytest
from elastica_magnetic_rl.cases.case import case_from_dict, load_case
from elastica_magnetic_rl.envs.yardsticks import RotatingFieldPolicy, yardstick_controller
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint

from elastica_magnetic.cli import main as msr
from elastica_magnetic.specfile import SpecError


def _with_field(period=0.5, clockwise=False, **extra):
    data = load_case("m1-4mT").to_dict()
    data["yardstick"].update(period=period, clockwise=clockwise, **extra)
    return data


def test_the_yardstick_field_is_read_written_and_played(tmp_path):
    assert set(load_case("m1-4mT").to_dict()["yardstick"]) == {"distance_10s", "source"}  # as before
    case = case_from_dict(_with_field(), "f.toml")
    assert (case.yardstick.period, case.yardstick.clockwise) == (0.5, False)
    again = tmp_path / "again.toml"
    again.write_text(case.toml())
    assert load_case(again).yardstick == case.yardstick
    controller = yardstick_controller(case)()
    assert isinstance(controller, RotatingFieldPolicy)
    assert (controller.period, controller.clockwise) == (0.5, False)
    assert yardstick_controller(load_case("m1-4mT")) is None  # no field recorded


@pytest.mark.parametrize(("change", "message"), [
    ({"period": 0.0}, "period"),
    ({"period": 0.015}, "at or under 2 x the 0.01 s control period"),
    ({"period": "1"}, "period"),
])
def test_a_yardstick_field_that_cannot_turn_is_refused(change, message):
    data = _with_field()
    data["yardstick"].update(change)
    with pytest.raises(SpecError, match=message):
        case_from_dict(data, "f.toml")
    data = load_case("m1-4mT").to_dict()
    data["yardstick"]["clockwise"] = True
    with pytest.raises(SpecError, match="the sense of a rotating field without its period"):
        case_from_dict(data, "f.toml")


def test_a_crawl_trained_from_its_rotating_field_plays_it_in_the_warm_up(tmp_path):
    """Also: a training in this process (one worker) leaves its torch threads as they were (2 left
    behind made the next test's small TD3 updates 50x slower beside a busy core)."""
    import torch

    spec = tmp_path / "rolling.toml"
    spec.write_text(case_from_dict(_with_field(period=1.0, clockwise=True), str(spec)).toml())
    torch.set_num_threads(1)
    assert msr(["train", "--case", str(spec), "--seeds", "1", "--workers", "1", "--threads", "2",
                "--steps", "150", "--episode-duration", "0.5", "--set", "learning_starts=120",
                "--set", "batch_size=32", "--set", "hidden_sizes=32,32", "--set", "yardstick_warmup=50",
                "--set", "eval_every=0", "--set", "exploration_noise=0", "--out", str(tmp_path / "runs"),
                "--no-progress"]) == 0
    assert torch.get_num_threads() == 1
    buffer = load_checkpoint(tmp_path / "runs" / "rolling" / "seed0")["buffer"]
    obs, actions = np.asarray(buffer["obs"])[:120], np.asarray(buffer["actions"])[:120]
    played = RotatingFieldPolicy(load_case(spec), 1.0, clockwise=True)
    np.testing.assert_allclose(actions, [played.act(o) for o in obs], atol=1e-6)


def test_dagger_on_a_crawl_labels_the_actor_s_states_with_the_rotating_field(tmp_path):
    """``yardstick_dagger`` on a crawl whose ``[yardstick]`` records its rotating field: the actor
    drives after the warm-up, and each of its observations is labelled with the field's command
    there (the field the observation shows, turned): labels of the observation alone."""
    import torch

    spec = tmp_path / "rolling.toml"
    spec.write_text(case_from_dict(_with_field(period=1.0, clockwise=True), str(spec)).toml())
    torch.set_num_threads(1)
    assert msr(["train", "--case", str(spec), "--seeds", "1", "--workers", "1", "--steps", "170",
                "--episode-duration", "0.5", "--set", "learning_starts=120", "--set", "batch_size=32",
                "--set", "hidden_sizes=32,32", "--set", "yardstick_warmup=50", "--set", "yardstick_dagger=40",
                "--set", "eval_every=0", "--set", "exploration_noise=0", "--out", str(tmp_path / "runs"),
                "--no-progress"]) == 0
    buffer = load_checkpoint(tmp_path / "runs" / "rolling" / "seed0")["buffer"]
    obs, actions, labels = (np.asarray(buffer[key])[:160] for key in ("obs", "actions", "labels"))
    played = RotatingFieldPolicy(load_case(spec), 1.0, clockwise=True)
    commanded = np.array([played.act(o) for o in obs])
    np.testing.assert_allclose(labels, commanded, atol=1e-6)
    np.testing.assert_allclose(actions[:120], commanded[:120], atol=1e-6)  # the warm-up: the field itself
    assert np.abs(actions[120:] - commanded[120:]).max() > 1e-3  # after it the actor drives
