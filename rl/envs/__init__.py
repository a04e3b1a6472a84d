"""The crawler as a Gymnasium environment: one robot (``env``), N robots in one batched simulator
(``vector_env``), and the recorded run of a policy (``rollout``)."""
