#!/usr/bin/env bash
# Create or reuse the virtual environment at .venv and install the project into it.
# Idempotent: re-installs only when setup.cfg / pyproject.toml / this script changed since the last install.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

py="${PYTHON:-python3.11}"
command -v "$py" >/dev/null 2>&1 || py=python3

if [ ! -x .venv/bin/python ]; then
  if ! "$py" -m venv .venv 2>/dev/null; then
    # Debian ships venv separately.
    if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
      apt-get update -qq && apt-get install -y -qq python3-venv >/dev/null
      rm -rf .venv && "$py" -m venv .venv
    else
      echo "error: '$py -m venv' failed; install python3-venv (Debian) and retry" >&2
      exit 1
    fi
  fi
fi

stamp=.venv/.msr-installed
want="$(cat setup.cfg pyproject.toml scripts/bootstrap.sh | sha256sum | cut -c1-16)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  echo "[bootstrap] installing the project into .venv (first time takes a few minutes)"
  quiet() { "$@" 2> >(grep -v "is ignored: it is neither a file nor a directory" >&2); }
  # torch is pinned to the CPU build (setup.cfg); install it first so nothing pulls a CUDA build.
  quiet .venv/bin/python -m pip install -q "torch==2.13.0"
  quiet .venv/bin/python -m pip install -q -e ".[dev,magnets]"
  echo "$want" > "$stamp"
fi
