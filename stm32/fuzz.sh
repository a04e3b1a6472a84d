#!/usr/bin/env bash
# Bounded-time fuzzing of the CSV row parser (fuzz/fuzz_csv_row.c) with libFuzzer + ASan/UBSan.
#   bash stm32/fuzz.sh [SECONDS]      (default 60; needs clang, installed from Debian as root)
# Prints the executions per second and exits non-zero on any crash, leak or UB report.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
seconds="${1:-60}"
if ! command -v clang >/dev/null || ! dpkg -s libclang-rt-dev >/dev/null 2>&1; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    DEBIAN_FRONTEND=noninteractive apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends clang libclang-rt-dev >/dev/null
  else
    echo "fuzz: clang not found (apt-get install clang)" >&2
    exit 1
  fi
fi
out="$here/build/fuzz"
mkdir -p "$out/corpus"
cp -n "$here"/fuzz/corpus/* "$out/corpus/" 2>/dev/null || true
clang -std=c11 -g -O1 -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
  -I "$here/src/app" "$here/fuzz/fuzz_csv_row.c" "$here/src/app/csv_row.c" -o "$out/fuzz_csv_row"
"$out/fuzz_csv_row" -max_total_time="$seconds" -max_len=512 -print_final_stats=1 \
  -artifact_prefix="$out/" "$out/corpus" 2>&1 | tee "$out/fuzz.log" | grep -E "^(#[0-9]+ +DONE|stat::|==|SUMMARY)" || true
grep -q "stat::number_of_executed_units" "$out/fuzz.log"
! grep -q "ERROR:" "$out/fuzz.log"
echo "fuzz: $(grep -m1 'stat::number_of_executed_units' "$out/fuzz.log" | awk '{print $2}') inputs in ${seconds} s, no crash"
