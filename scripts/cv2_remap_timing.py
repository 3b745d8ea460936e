#!/usr/bin/env python3
"""cv2.remap timed on one thread on the map `fusion-engine`'s remap_time example wrote (never part of CI).

Needs `pip install opencv-python-headless numpy`. Usage: cv2_remap_timing.py DIR. Prints the
median of 50 calls (after 5 warm-up calls) for linear and cubic, and whether cv2's bytes equal
the core's (`out_linear.u8`, `out_cubic.u8`).
"""
import os, sys, time
import cv2
import numpy as np

d = sys.argv[1]
w = h = 1024
xy = np.fromfile(os.path.join(d, "map_xy.i16"), dtype="<i2").reshape(h, w, 2)
frac = np.fromfile(os.path.join(d, "map_frac.u16"), dtype="<u2").reshape(h, w)
tir = np.fromfile(os.path.join(d, "tir.u8"), dtype=np.uint8).reshape(512, 512)
cv2.setNumThreads(1)
print(f"OpenCV {cv2.__version__}, {cv2.getNumThreads()} thread")
for name, flag in [("linear", cv2.INTER_LINEAR), ("cubic", cv2.INTER_CUBIC)]:
    f = lambda: cv2.remap(tir, xy, frac, flag, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    for _ in range(5):
        f()
    ts = []
    for _ in range(50):
        t0 = time.perf_counter_ns(); r = f(); ts.append(time.perf_counter_ns() - t0)
    ours = np.fromfile(os.path.join(d, f"out_{name}.u8"), dtype=np.uint8).reshape(h, w)
    diff = int(np.count_nonzero(ours != r))
    print(f"| remap {name} 8-bit | {np.median(ts) / 1e6:.2f} ms | pixels differing from the core: {diff} |")
