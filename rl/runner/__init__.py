"""The training loop: K seeds on one vector environment (``loop``: :func:`train_seeds`), each seed's
bookkeeping (``seed_run``), evaluation during and after training (``evaluation``) and the allocator
setting that keeps the update fast (``allocator``)."""
