#!/usr/bin/env python3
"""profile.py ELF PROFILE: fold per-PC counts from the plugin into functions."""
import subprocess, sys, bisect, collections
elf, prof = sys.argv[1], sys.argv[2]
syms = []
for line in subprocess.run(["llvm-nm", "-C", "-S", "--defined-only", elf], capture_output=True, text=True).stdout.splitlines():
    parts = line.split(None, 3)
    if len(parts) == 4 and parts[2] in "tTwW":
        syms.append((int(parts[0], 16) & ~1, int(parts[1], 16), parts[3]))
syms.sort()
starts = [s[0] for s in syms]
per = collections.Counter()
total = 0
for line in open(prof):
    pc, n = line.split(); pc = int(pc, 16); n = int(n); total += n
    i = bisect.bisect_right(starts, pc) - 1
    name = syms[i][2] if i >= 0 and pc < syms[i][0] + max(syms[i][1], 2) else "?"
    per[name] += n
print(f"{total} insns in window")
for name, n in per.most_common(15):
    print(f"{n:>10} {100*n/total:5.1f}%  {name[:100]}")
