"""The ``msr`` command line, in its own subpackage: ``app`` (the dispatcher: parses, finds each area's
sub-commands by module name, reports a :class:`CommandError` as one line; the helpers every command
module uses) and ``commands`` (the physics package's own sub-commands, ``replay`` and ``simulate``).
``python -m elastica_magnetic.cli`` runs ``msr``.
"""

from .app import (
    COMMAND_MODULES,
    GROUPS,
    OUTPUT_TYPES,
    CommandError,
    build_parser,
    command_name,
    duration_option,
    heading_option,
    interrupted_message,
    listed_commands,
    main,
    number,
    output_path,
    print_notes,
    print_result,
)

__all__ = ["COMMAND_MODULES", "GROUPS", "OUTPUT_TYPES", "CommandError", "build_parser",
           "command_name", "duration_option", "heading_option", "interrupted_message", "listed_commands",
           "main", "number", "output_path", "print_notes", "print_result"]
