"""``python -m elastica_magnetic.cli``: the ``msr`` command line."""

import sys

from elastica_magnetic.cli import main

sys.exit(main())
