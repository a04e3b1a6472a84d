"""The learning package's ``msr`` sub-commands: thin wrappers (parse, call the library, print).
``commands``: ``case``, ``train``, ``bench``, ``refine``, ``generate``, ``baseline``, ``figures``,
``demo``; ``policy_commands``: ``export-seeds``, ``seeds``, ``ship``, ``notes``, ``export``,
``diagnose``."""
