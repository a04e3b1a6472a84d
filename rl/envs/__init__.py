"""The crawler as a Gymnasium environment: one robot (``env``), N robots in one batched simulator
(``vector_env``), the recorded run of a policy (``rollout``), and the hand-designed controllers that
act through the same observation and action (``yardsticks``: the rotating field, the steering
field)."""
