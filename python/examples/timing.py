"""Times vistir.fuse on the firmware's budget pair (VIS 1024², TIR 512²) and its fixed cost on a
tiny frame: what the Python binding adds to the core. Medians of --repeats runs, one thread.

    python python/examples/timing.py [--repeats 7]
"""

import argparse
import platform
import statistics
import time
from pathlib import Path

import numpy as np
import vistir

REPO = Path(__file__).resolve().parents[2]


def median_ms(f, repeats):
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return 1000 * statistics.median(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=7)
    args = ap.parse_args()
    vis = vistir.load(REPO / "fw" / "data" / "tango_vis_light_1024.png")
    tir = vistir.load(REPO / "fw" / "data" / "tango_tir_512.png")
    vis_f, tir_f = np.asfortranarray(vis), np.asfortranarray(tir)  # column-major: copied once
    tiny_v, tiny_t = vis[:8, :8].copy(), tir[:4, :4].copy()
    print(f"{platform.processor() or platform.machine()}, Python {platform.python_version()}, numpy {np.__version__}")
    print("| method | vistir.fuse, C-order (ms) | Fortran-order input (ms) | 8²/4² frame (µs) |")
    print("|---|---:|---:|---:|")
    for method in ["tsifsd", "adf", "ifevip", "adaptive"]:
        big = median_ms(lambda: vistir.fuse(vis, tir, method=method), args.repeats)
        copied = median_ms(lambda: vistir.fuse(vis_f, tir_f, method=method), args.repeats)
        tiny = median_ms(lambda: vistir.fuse(tiny_v, tiny_t, method=method), 200) * 1000
        print(f"| {method} | {big:.2f} | {copied:.2f} | {tiny:.0f} |")


if __name__ == "__main__":
    main()
