"""The algorithm: TD3 for K seeds at once (hyperparameters, networks, the update), its replay buffer,
exploration noise and the one-seed agent. Knows nothing of robots or environments.

Modules: ``algorithm`` (:class:`TD3Config`, :class:`TD3`), ``networks`` (one seed's actor and
critic as plain modules), ``stacked`` (K networks as one
computation), ``replay_buffer``, ``exploration`` (coloured noise), ``agent`` (one seed)."""
