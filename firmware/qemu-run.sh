#!/usr/bin/env bash
# cargo runner: qemu-run.sh <elf> -> runs it on QEMU (machine $QEMU_MACHINE,
# default netduinoplus2 = STM32F405, Cortex-M4F), decodes the defmt stream
# (semihosting SYS_WRITE -> QEMU stdout) and exits with the firmware's exit
# status (124 = hang/timeout). Decoder: `cargo xtask defmt-decode` when run
# through xtask (it sets GPECNET_XTASK to its own binary), else defmt-print.
set -uo pipefail
elf="$1"
raw="${elf}.defmt"
command -v qemu-system-arm >/dev/null || { echo "qemu-system-arm missing: apt-get install -y --no-install-recommends qemu-system-arm" >&2; exit 2; }
if [ -n "${GPECNET_XTASK:-}" ] && [ -x "$GPECNET_XTASK" ]; then
  decode=("$GPECNET_XTASK" defmt-decode "$elf")
elif command -v defmt-print >/dev/null; then
  decode=(defmt-print -e "$elf")
else
  echo "no defmt decoder: run through cargo xtask (fw-run, qemu), or: cargo install defmt-print --locked" >&2
  exit 2
fi
# Outer safety net only: hangs are caught by the firmware supervisor within
# 10 s of emulated time; the M0 soft-float replay takes ~1-2 min on a busy box.
timeout "${QEMU_TIMEOUT:-600}" qemu-system-arm -machine "${QEMU_MACHINE:-netduinoplus2}" -nographic \
  -monitor none -serial null \
  -semihosting-config enable=on,target=native \
  -kernel "$elf" > "$raw"
rc=$?
"${decode[@]}" < "$raw"
exit $rc
