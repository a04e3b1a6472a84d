"""DAgger after the yardstick's clone (``yardstick_dagger``, rl/runner/group.py): the actor drives,
the yardstick labels each observation the actor meets, the actor's updates are clone steps on
those labels, the labels travel in the replay file, and a killed run resumes exactly."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from elastica_magnetic_rl.runfiles.checkpoint import load_checkpoint
from elastica_magnetic_rl.runner.loop import train
from elastica_magnetic_rl.td3.config import TD3Config
from elastica_magnetic_rl.td3.replay_buffer import ReplayBuffer
from state_compare import assert_state_equal
from toy_env import Killed, ToyEnv, toy_config

torch.set_num_threads(1)
WARM_UP, DAGGER = 120, 300


class Teacher:
    """The toy task's controller: toward the target at up to full speed, the second action at
    the middle of its range; as DAgger's teacher it labels with the opposite first action (labels
    that differ from the warm-up's, so the test sees which ones the actor learned)."""

    obs_dim, act_dim = 3, 2

    def reset(self) -> None:
        pass

    def state(self) -> None:
        return None

    def set_state(self, state) -> None:
        pass

    def act(self, obs: np.ndarray) -> np.ndarray:
        return np.array([np.clip(5.0 * (obs[1] - obs[0]), -1.0, 1.0), 0.0], dtype=np.float32)

    def label(self, obs: np.ndarray) -> np.ndarray:
        return np.array([-np.clip(5.0 * (obs[1] - obs[0]), -1.0, 1.0), 0.0], dtype=np.float32)


def _fixed() -> ToyEnv:
    return ToyEnv(p_terminate=0.0)


def _config(**kw) -> TD3Config:
    base = dict(learning_starts=WARM_UP, yardstick_warmup=600, yardstick_dagger=DAGGER, exploration_noise=0.1,
                batch_size=32, hidden_sizes=(32, 32), checkpoint_every=40, eval_every=0, seed=3)
    return toy_config(**{**base, **kw})


def _rows(run_dir) -> dict[str, np.ndarray]:
    buffer = load_checkpoint(run_dir)["buffer"]
    return {key: np.asarray(buffer[key]) for key in ("obs", "actions", "labels")}


def test_the_actor_drives_the_yardstick_labels_and_the_actor_learns_the_labels(tmp_path):
    steps = WARM_UP + DAGGER + 20
    agent = train(_fixed, _config(), steps, tmp_path / "dagger", progress=False, yardstick_fn=Teacher)
    rows, teacher = _rows(tmp_path / "dagger"), Teacher()
    warm, dagger, after = slice(0, WARM_UP), slice(WARM_UP, WARM_UP + DAGGER), slice(WARM_UP + DAGGER, steps)
    # the warm-up: the yardstick's own command is the label, its action that plus the noise
    shown = np.array([teacher.act(o) for o in rows["obs"][warm]])
    np.testing.assert_array_equal(rows["labels"][warm], shown)
    assert float(np.abs(rows["actions"][warm] - shown).mean()) < 0.15
    # DAgger: every observation labelled by the teacher, the actions the actor's, not the labels
    labels = np.array([teacher.label(o) for o in rows["obs"][dagger]])
    np.testing.assert_array_equal(rows["labels"][dagger], labels)
    assert float(np.abs(rows["actions"][dagger, 0] - labels[:, 0]).mean()) > 0.1
    assert not rows["labels"][after].any()  # past DAgger: TD3, no labels
    # the actor learned the labels (the opposite of the warm-up it was cloned from)
    with torch.no_grad():
        acted = torch.tanh(agent.actor.net(torch.as_tensor(rows["obs"][dagger]))).numpy()
    to_labels = float(np.abs(acted[:, 0] - labels[:, 0]).mean())
    to_warm_up = float(np.abs(acted[:, 0] + labels[:, 0]).mean())
    assert to_labels < 0.5 * to_warm_up, (to_labels, to_warm_up)


@pytest.mark.parametrize("kill_at", [WARM_UP + 50, WARM_UP + DAGGER + 10])  # inside DAgger, after it
def test_a_run_killed_and_resumed_ends_as_one_uninterrupted(tmp_path, kill_at):
    steps, config = WARM_UP + DAGGER + 40, _config(yardstick_warmup=200)

    full = train(_fixed, config, steps, tmp_path / "full", progress=False, yardstick_fn=Teacher)

    def kill(row):
        if row["global_step"] >= kill_at:
            raise Killed

    with pytest.raises(Killed):
        train(_fixed, config, steps, tmp_path / "cut", progress=False, yardstick_fn=Teacher, log_fn=kill)
    assert load_checkpoint(tmp_path / "cut")["global_step"] < kill_at
    resumed = train(_fixed, config, steps, tmp_path / "cut", resume=True, progress=False,
                    yardstick_fn=Teacher)
    assert_state_equal(full.state_dict(), resumed.state_dict())
    a, b = load_checkpoint(tmp_path / "full"), load_checkpoint(tmp_path / "cut")
    for key in ("agent", "buffer", "global_step", "episode"):
        assert_state_equal(a[key], b[key], key)
    assert "labels" in a["buffer"]


def test_a_labelled_buffer_needs_labels_and_keeps_them_through_its_state():
    buffer = ReplayBuffer(8, 3, 2, labelled=True)
    with pytest.raises(ValueError, match="needs each transition's label"):
        buffer.add(np.zeros(3), np.zeros(2), 0.0, np.zeros(3), False)
    for i in range(5):
        buffer.add(np.full(3, i), np.full(2, -i), float(i), np.full(3, i + 1), False, np.full(2, 10 * i))
    again = ReplayBuffer(8, 3, 2, labelled=True)
    again.load_state_dict(buffer.state_dict())
    np.testing.assert_array_equal(again.labels[:5, 0], [0, 10, 20, 30, 40])
    batch = again.sample_labels(16, np.random.default_rng(0))
    np.testing.assert_array_equal(batch.actions[:, 0], 10 * batch.obs[:, 0])
    with pytest.raises(ValueError, match="holds no labels"):
        ReplayBuffer(8, 3, 2).sample_labels(4, np.random.default_rng(0))
    with pytest.raises(ValueError, match="not written by a run with yardstick_dagger"):
        again.load_state_dict(ReplayBuffer(8, 3, 2).state_dict())


def test_dagger_without_a_warm_up_is_refused_and_a_goto_case_accepted():
    with pytest.raises(ValueError, match="yardstick_dagger 100 continues a clone .* set yardstick_warmup"):
        TD3Config(yardstick_dagger=100)
    with pytest.raises(ValueError, match="yardstick_dagger must be >= 0"):
        TD3Config(yardstick_dagger=-1, yardstick_warmup=10, learning_starts=256)
    assert TD3Config.parse_setting("yardstick_dagger", "20000") == 20000
    from elastica_magnetic_rl.cases.case import case_from_dict, load_case, warmup_refusal
    from elastica_magnetic_rl.sweep.sweep_plan import _check_yardstick_warmup

    dagger = TD3Config(yardstick_dagger=500, yardstick_warmup=10, learning_starts=256)
    goto = load_case("m1-4mT-goto")  # its memoryless steering law labels any state
    _check_yardstick_warmup({goto.name: goto}, dagger)
    data = goto.to_dict()  # its own [training.td3] trains a residual learner: a clone instead
    data.setdefault("training", {}).setdefault("td3", {}).update(yardstick_dagger=500, yardstick_warmup=10,
                                                                 residual=0.0, correction_penalty=0.0)
    assert case_from_dict(data, "goto-dagger").training.td3["yardstick_dagger"] == 500
    crawl = load_case("m1-4mT-designed")  # its [yardstick] records its rotating field: it labels
    _check_yardstick_warmup({crawl.name: crawl}, dagger)
    data = crawl.to_dict()
    data.setdefault("training", {}).setdefault("td3", {}).update(yardstick_dagger=500, yardstick_warmup=10)
    assert warmup_refusal(case_from_dict(data, "crawl-dagger")) is None
    coils = load_case("catheter-coils-reach")
    _check_yardstick_warmup({coils.name: coils}, TD3Config(yardstick_dagger=500, yardstick_warmup=10,
                                                           learning_starts=256))


def test_a_clone_of_the_commands_copies_the_yardstick_not_its_noise(tmp_path):
    # a warm-up with much exploration noise, cloned on the actions as played and as commanded: the
    # buffers (and so the paths) are the same; the clone of the commands is nearer the teacher
    steps, noise = WARM_UP + 1, 0.6
    cloned = {}
    for labels in ("played", "commanded"):
        config = _config(yardstick_dagger=0, clone_labels=labels, exploration_noise=noise,
                         yardstick_warmup=2000)
        cloned[labels] = train(_fixed, config, steps, tmp_path / labels, progress=False, yardstick_fn=Teacher)
    played = load_checkpoint(tmp_path / "played")["buffer"]
    commanded = load_checkpoint(tmp_path / "commanded")["buffer"]
    np.testing.assert_array_equal(np.asarray(played["actions"]), np.asarray(commanded["actions"]))
    assert "labels" not in played
    rows, teacher = _rows(tmp_path / "commanded"), Teacher()
    shown = np.array([teacher.act(o) for o in rows["obs"][:WARM_UP]])
    np.testing.assert_array_equal(rows["labels"][:WARM_UP], shown)
    obs = torch.as_tensor(rows["obs"][:WARM_UP])
    with torch.no_grad():
        errors = {labels: float(np.abs(torch.tanh(agent.actor.net(obs)).numpy() - shown).mean())
                  for labels, agent in cloned.items()}
    # the played actions' noise (clipped to [-1, 1]) is what the clone of the played ones carries
    assert errors["commanded"] < 0.5 * errors["played"], errors


def test_a_clone_of_the_commands_needs_a_warm_up_and_names_its_choices():
    with pytest.raises(ValueError, match="clone_labels 'commanded' copies the yardstick's own commands"):
        TD3Config(clone_labels="commanded")
    with pytest.raises(ValueError, match="clone_labels must be one of played, commanded, got 'clean'"):
        TD3Config(clone_labels="clean", yardstick_warmup=10, learning_starts=256)
    assert TD3Config.parse_setting("clone_labels", "commanded") == "commanded"
    with pytest.raises(ValueError, match="clone_labels=clean: expected played or commanded"):
        TD3Config.parse_setting("clone_labels", "clean")
    assert TD3Config(clone_labels="commanded", yardstick_warmup=10, learning_starts=256).labelled
    assert not TD3Config().labelled
