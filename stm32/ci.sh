#!/usr/bin/env bash
# Firmware checks for scripts/test.sh: install the Debian packages that are missing (as root),
# build and run the host unit tests (cmocka, CTest), and cross-build the firmware ELF for the
# STM32F407 with -Wall -Wextra -Werror. Idempotent; a warm machine skips the install.
# The QEMU end-to-end test runs from pytest (tests/hardware/test_qemu_e2e.py) on the ELF built here.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
cd "$root"

packages=(gcc-arm-none-eabi libnewlib-arm-none-eabi binutils-arm-none-eabi qemu-system-arm
          libcmocka-dev cmake pkg-config make gcc)
missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
    echo "[stm32] installing: ${missing[*]}"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
  else
    echo "[stm32] error: missing Debian packages: ${missing[*]} (run as root or install them)" >&2
    exit 1
  fi
fi

# Python for the build-time generators (calibration header, flash table): the project's venv.
python="${MSR_PYTHON:-}"
if [ -z "$python" ]; then
  if [ -x "$root/.venv/bin/python" ]; then python="$root/.venv/bin/python"; else python=python3; fi
fi

jobs="$(nproc 2>/dev/null || echo 2)"

echo "[stm32] host unit tests"
cmake -S stm32 -B stm32/build/host -DCMAKE_BUILD_TYPE=Debug >/dev/null
cmake --build stm32/build/host -j "$jobs"
ctest --test-dir stm32/build/host --output-on-failure

echo "[stm32] firmware ELF (arm-none-eabi, -Wall -Wextra -Werror)"
cmake -S stm32 -B stm32/build/arm -DCMAKE_TOOLCHAIN_FILE=cmake/arm-none-eabi.cmake \
  -DCMAKE_BUILD_TYPE=Release -DMSR_PYTHON="$python" >/dev/null
cmake --build stm32/build/arm -j "$jobs"
test -f stm32/build/arm/msr_firmware.elf
echo "[stm32] built stm32/build/arm/msr_firmware.elf"
