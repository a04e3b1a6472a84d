"""The learning package's ``msr`` sub-commands: thin wrappers (parse, call the library, print).
``commands``: ``case``, ``bench``, ``generate``, ``baseline``, ``figures``, ``demo``;
``train_commands``: ``train``, ``refine``; ``policy_commands``: ``export-seeds``, ``seeds``, ``ship``,
``notes``, ``export``, ``diagnose``; ``options``: what they share (``--case``, help texts)."""
