"""What ``msr`` imports before it knows the command: building the parser (every command's options
and their checks) must not import PyTorch, whose import costs seconds that every ``msr --help``,
every refused option and every hardware command would otherwise pay."""

import subprocess
import sys


def test_building_the_parser_imports_no_torch():
    code = ("import sys\n"
            "from elastica_magnetic.cli.app import build_parser\n"
            "build_parser()\n"
            "print(sorted(m for m in sys.modules if m == 'torch' or m.startswith('torch.')))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout[:500]
