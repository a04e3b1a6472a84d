"""What to learn: cases (a robot, its actuation, a task, a recipe and a yardstick, from a spec file in
``specs/``), tasks (reward and success) and the named training recipes.

Modules: ``case`` (:class:`Case`, :func:`load_case`), ``tasks``, ``recipes``."""
