"""The algorithm: TD3 for K seeds at once (hyperparameters, networks, the update), its replay buffer,
exploration noise and the one-seed agent. Knows nothing of robots or environments.

Modules: ``algorithm`` (:class:`TD3Config`, networks, :class:`TD3`), ``stacked`` (K networks as one
computation), ``replay_buffer``, ``exploration`` (coloured noise), ``agent`` (one seed)."""
