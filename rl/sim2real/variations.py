"""Moved: the variations of a spec (dotted keys, ranges, designs) live in
:mod:`elastica_magnetic_rl.cases.variations`, beside the cases they vary (training randomizes them
too); this module keeps the old import path."""

from ..cases.variations import *  # noqa: F401,F403
from ..cases.variations import __all__  # noqa: F401
