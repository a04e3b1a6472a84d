"""The ``msr`` command line, in its own subpackage: ``app`` (the dispatcher: parses, finds each area's
sub-commands by module name, reports a :class:`CommandError` as one line; the printing helpers every
command module uses), ``options`` (the argparse types every command module uses: numbers with their
unit, headings, the path rule of output options, ``--duration``) and ``commands`` (the physics
package's own sub-commands, ``replay`` and ``simulate``).
``python -m elastica_magnetic.cli`` runs ``msr``.
"""

from .app import (
    COMMAND_MODULES,
    GROUPS,
    CommandError,
    build_parser,
    command_name,
    interrupted_message,
    listed_commands,
    main,
    print_notes,
    print_result,
)
from .options import OUTPUT_TYPES, duration_option, heading_option, number, output_path

__all__ = ["COMMAND_MODULES", "GROUPS", "OUTPUT_TYPES", "CommandError", "build_parser",
           "command_name", "duration_option", "heading_option", "interrupted_message", "listed_commands",
           "main", "number", "output_path", "print_notes", "print_result"]
