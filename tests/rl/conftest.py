"""Shared pieces of the learning package's tests. The helper modules beside this file
(``state_compare``, ``toy_data``) are imported by name from the test folders below it: pytest puts
this folder on ``sys.path`` because it holds a ``conftest.py``."""
