"""The two ``msr loop`` examples of a lab's own robot (docs/examples): one robot, two trainings."""

from __future__ import annotations

from pathlib import Path

from elastica_magnetic_rl.cases.case import load_case, warmup_refusal

EXAMPLES = Path(__file__).resolve().parents[3] / "docs" / "examples"


def test_the_clone_example_is_the_same_robot_trained_from_its_yardstick():
    """mybot_loop_clone.toml is mybot_loop.toml with a training that clones the loop's yardstick
    (the rotating field its sweep finds) before TD3: every table but [training] the same, and the
    warm-up refused by msr train alone until the loop's sweep records the field's period."""
    plain, clone = (load_case(EXAMPLES / name) for name in ("mybot_loop.toml", "mybot_loop_clone.toml"))
    a, b = plain.to_dict(), clone.to_dict()
    assert {k: v for k, v in a.items() if k != "training"} == {k: v for k, v in b.items() if k != "training"}
    td3 = b["training"]["td3"]
    assert b["training"]["steps"] > td3["learning_starts"] > td3["yardstick_warmup"] > 0
    assert warmup_refusal(plain) is None and "give [yardstick] period" in warmup_refusal(clone)
