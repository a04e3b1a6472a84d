#!/usr/bin/env bash
# The main job: `msr policy demo`. The shipped pattern-1 4 mT policy drives the paper's robot for 10 s in
# the accurate physics from a zero field; writes out/demo/fields.csv (mT, 100 Hz: the waveform for the
# coils), trajectory.csv, the figures and gait.gif. A few minutes. Extra arguments go to `msr policy demo`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
bash scripts/bootstrap.sh
export MPLBACKEND=Agg
.venv/bin/msr policy demo --out out/demo "$@"
