#!/usr/bin/env python3
"""Where the instructions of a firmware run go: sums the per-block profile that
fw/plugin/insn_count.c writes with `profile=PATH` over the functions of the image.

    scripts/arm_profile.py IMAGE.elf PROFILE.txt [--top N]     # per function
    scripts/arm_profile.py IMAGE.elf PROFILE.txt --blocks N    # the N hottest blocks

How to get PROFILE.txt: run `fusion budget --target arm ... --out DIR` once, then rerun one
of its job folders (DIR/arm-1024-budget-0 holds job.bin, vis.gray, tir.gray) with the
plugin's profile option:

    cd DIR/arm-1024-budget-0 && qemu-system-arm -machine mps2-an500 -cpu cortex-m7 \\
      -nographic -semihosting-config enable=on,target=native \\
      -kernel ../fusion-fw-arm-1024.elf -d plugin -D plugin.log \\
      -plugin ../libinsn_count.so,begin=0xB,end=0xE,profile=prof.txt

(B and E: the addresses of fw_region_begin and fw_region_end, from llvm-nm). The profile
covers the whole run, every region of the job. Needs llvm-nm (`rustup component add
llvm-tools`). Functions inlined by LTO count as their caller: mark a function
`#[inline(never)]` for a study to see it on its own.
"""
import argparse
import bisect
import collections
import glob
import shutil
import subprocess


def functions(elf):
    sysroot = subprocess.check_output(["rustc", "--print", "sysroot"], text=True).strip()
    # rustup's llvm-tools, else the system's llvm-nm.
    nm = (sorted(glob.glob(f"{sysroot}/lib/rustlib/*/bin/llvm-nm")) + [shutil.which("llvm-nm") or "llvm-nm"])[0]
    out = subprocess.check_output([nm, "--numeric-sort", "--print-size", "--demangle", elf], text=True)
    syms = []
    for line in out.splitlines():
        parts = line.split(maxsplit=3)
        if len(parts) == 4 and parts[2] in ("T", "t"):
            addr = int(parts[0], 16) & ~1
            syms.append((addr, int(parts[1], 16), parts[3]))
    syms.sort()
    return syms


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("elf")
    ap.add_argument("profile")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--blocks", type=int, default=0)
    args = ap.parse_args()
    blocks = collections.Counter()
    for line in open(args.profile):
        pc, insns, execs = line.split()
        blocks[int(pc, 16)] += int(insns) * int(execs)
    total = sum(blocks.values())
    syms = functions(args.elf)
    starts = [s[0] for s in syms]

    def owner(pc):
        i = bisect.bisect_right(starts, pc) - 1
        if i >= 0 and pc < syms[i][0] + max(syms[i][1], 1):
            return syms[i][2]
        return "?"

    if args.blocks:
        for pc, n in blocks.most_common(args.blocks):
            print(f"{pc:#010x} {n:14d} {100 * n / total:6.2f} %  {owner(pc)}")
    else:
        by = collections.Counter()
        for pc, n in blocks.items():
            by[owner(pc)] += n
        for name, n in by.most_common(args.top):
            print(f"{n:14d} {100 * n / total:6.2f} %  {name}")
    print(f"{total:14d} total")


if __name__ == "__main__":
    main()
