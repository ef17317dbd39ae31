#!/usr/bin/env bash
# cargo runner: qemu-run.sh <elf> -> runs it on QEMU netduinoplus2 (STM32F405,
# Cortex-M4F), decodes the defmt stream (semihosting SYS_WRITE -> QEMU stdout)
# with defmt-print, exits with the firmware's exit status (124 = hang/timeout).
set -uo pipefail
elf="$1"
raw="${elf}.defmt"
command -v qemu-system-arm >/dev/null || { echo "qemu-system-arm missing: apt-get install -y --no-install-recommends qemu-system-arm" >&2; exit 2; }
command -v defmt-print >/dev/null || { echo "defmt-print missing: cargo install defmt-print --locked" >&2; exit 2; }
timeout "${QEMU_TIMEOUT:-120}" qemu-system-arm -machine "${QEMU_MACHINE:-netduinoplus2}" -nographic \
  -monitor none -serial null \
  -semihosting-config enable=on,target=native \
  -kernel "$elf" > "$raw"
rc=$?
defmt-print -e "$elf" < "$raw"
exit $rc
