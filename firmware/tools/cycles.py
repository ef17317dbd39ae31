#!/usr/bin/env python3
"""cycles.py ELF PCPROF: a Cortex-M4 cycle estimate for a QEMU per-PC profile.

QEMU counts instructions, not cycles. This weighs each executed instruction
(the per-PC counts of `cargo xtask profile`, target/fw-profile/<m>-<p>.pcprof,
with the image's disassembly by arm-none-eabi-objdump) with its Cortex-M4
issue cycles from the Technical Reference Manual (r0p1, "Processor instruction
timings"), as a range:

  low:  single loads/stores 1 (pipelined), LDRD/STRD 2, taken branch 1 + 1,
        IT folded (0), VMLA 1 (no dependent stall)
  high: single loads/stores 2, LDRD/STRD 3, taken branch 1 + 3, IT 1, VMLA 3

both with LDM/STM/PUSH/POP/VLDM/VSTM/VPUSH/VPOP 1 + N (N registers), VDIV and
VSQRT 14, UDIV/SDIV 2..12 (low/high), every other integer, multiply (incl.
SMLALD, UMULL, MLA) and single-precision VFP instruction 1. A conditional
branch counts as taken as often as the profile shows: its count minus that of
the next instruction (a lower bound when the next one is also a branch target).

Not modelled: flash wait states (the ART accelerator's prefetch and 1 KiB
I-cache hide them for code in loops; data read from flash, e.g. the weights of
a blob embedded in flash, pay them on an ART data-cache miss, see
firmware/README.md) and bus contention. So "high" is not a hard upper bound
for weights in flash; for weights in SRAM both bounds hold.

Prints the instruction count, the cycle range, CPI, and cycles by class.
"""
import collections
import re
import signal
import subprocess
import sys

signal.signal(signal.SIGPIPE, signal.SIG_DFL)  # `| head` ends quietly

elf, prof = sys.argv[1], sys.argv[2]
counts = {}
for line in open(prof):
    pc, n = line.split()
    counts[int(pc, 16)] = int(n)

# Disassembly: address -> (mnemonic, operands), in address order.
insns = []
dump = subprocess.run(
    ["arm-none-eabi-objdump", "-d", "--no-show-raw-insn", elf],
    capture_output=True, text=True, check=True,
).stdout
line_re = re.compile(r"^\s*([0-9a-f]+):\s+(\S+)\s*(.*)$")
for line in dump.splitlines():
    m = line_re.match(line)
    if m:
        insns.append((int(m.group(1), 16), m.group(2), m.group(3)))
next_addr = {a: insns[i + 1][0] for i, (a, _, _) in enumerate(insns[:-1])}
by_addr = {a: (mn, ops) for a, mn, ops in insns}

CONDS = ("eq", "ne", "cs", "cc", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le", "hs", "lo")


def base(mn):
    """The mnemonic without its .w/.n/.f32 width suffixes."""
    return mn.split(".")[0]


def is_branch(b):
    if b in ("b", "bl", "blx", "bx", "cbz", "cbnz", "tbb", "tbh"):
        return True
    return b.startswith("b") and b[1:] in CONDS or (b.startswith("bx") and b[2:] in CONDS)


def nregs(ops):
    """Registers in a {...} list (ranges like r4-r7 or s0-s11 expanded)."""
    m = re.search(r"\{([^}]*)\}", ops)
    if not m:
        return 1
    n = 0
    for part in m.group(1).split(","):
        part = part.strip()
        r = re.match(r"([a-z]+)(\d+)-[a-z]+(\d+)", part)
        n += int(r.group(3)) - int(r.group(2)) + 1 if r else 1
    return n


def cost(addr, mn, ops, n):
    """(class, low cycles, high cycles) for `n` executions at `addr`."""
    b = base(mn)
    pc_written = "pc" in ops.split("{")[-1] if b in ("pop", "ldmia", "ldm") else False
    if is_branch(b):
        cond = b not in ("b", "bl", "blx", "bx", "tbb", "tbh")
        taken = n
        if cond:
            nxt = next_addr.get(addr)
            taken = max(0, n - counts.get(nxt, 0)) if nxt is not None else n
        return "branch", n + taken * 1, n + taken * 3
    if b.startswith("it"):
        return "it", 0, n
    if b in ("vdiv", "vsqrt"):
        return "vdiv/vsqrt", 14 * n, 14 * n
    if b in ("udiv", "sdiv"):
        return "div", 2 * n, 12 * n
    if b in ("push", "pop", "stmdb", "stmia", "stm", "ldmia", "ldm", "ldmdb", "vpush", "vpop", "vldmia", "vstmia", "vldm", "vstm", "vstmdb"):
        c = (1 + nregs(ops)) * n + (3 * n if pc_written else 0)
        return "load/store multiple", c, c
    if b.startswith("ldrd") or b.startswith("strd"):
        return "ldrd/strd", 2 * n, 3 * n
    if b.startswith("vldr") or b.startswith("vstr"):
        return "vldr/vstr", 2 * n, 2 * n
    if re.match(r"^(ldr|str)(b|h|sb|sh|ex)?(" + "|".join(CONDS) + r")?$", b):
        return "load/store", n, 2 * n
    if b.startswith("vmla") or b.startswith("vmls"):
        return "vmla", n, 3 * n
    if b.startswith("v"):
        return "vfp", n, n
    return "alu/mul", n, n


total = lo = hi = 0
classes = collections.defaultdict(lambda: [0, 0, 0])
unknown = 0
for addr, n in counts.items():
    if addr not in by_addr:
        unknown += n
        continue
    mn, ops = by_addr[addr]
    k, l, h = cost(addr, mn, ops, n)
    total += n
    lo += l
    hi += h
    c = classes[k]
    c[0] += n
    c[1] += l
    c[2] += h
print(f"instructions {total}" + (f" (+{unknown} at addresses without disassembly)" if unknown else ""))
print(f"cycles low {lo}  high {hi}  (CPI {lo / max(total, 1):.2f} .. {hi / max(total, 1):.2f})")
print(f"{'class':<22}{'insns':>10}{'cycles low':>12}{'high':>10}")
for k, (n, l, h) in sorted(classes.items(), key=lambda kv: -kv[1][2]):
    print(f"{k:<22}{n:>10}{l:>12}{h:>10}")
