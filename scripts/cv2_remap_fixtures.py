#!/usr/bin/env python3
"""OpenCV's remap outputs for the registration tests (tests/tests/registration.rs).

Needs `pip install opencv-python-headless numpy`. Writes into tests/data/remap/: two source
frames (8-bit and 16-bit, 61 x 47, a smooth pattern plus noise and hard edges), a fixed-point map
of 64 x 48 output pixels (a perspective warp reaching 6 px past every border, then a band of
random positions; cv2.convertMaps to CV_16SC2 + CV_16UC1, stored as map_x, map_y, map_frac)
and cv2.remap's result for each depth x {linear, cubic} x {constant 0, constant 1/3 of full
scale, replicate}, plus versions.txt naming the OpenCV and NumPy that made them.
"""
import os, sys
import cv2
import numpy as np

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "remap")
os.makedirs(out, exist_ok=True)
rng = np.random.default_rng(41)
W, H = 61, 47
yy, xx = np.mgrid[0:H, 0:W].astype(np.float64)
base = 0.5 + 0.35 * np.sin(xx / 5.0) * np.cos(yy / 7.0) + 0.1 * (xx > 30) - 0.1 * (yy > 20)
base = np.clip(base + 0.05 * rng.standard_normal((H, W)), 0, 1)
src8 = np.rint(base * 255).astype(np.uint8)
src16 = np.rint(base * 65535).astype(np.uint16)

w, h = 64, 48
v, u = np.mgrid[0:h, 0:w].astype(np.float64)
Hm = np.array([[1.05, 0.04, -6.0], [-0.03, 1.02, -6.0], [0.0004, -0.0003, 1.0]])
den = Hm[2, 0] * u + Hm[2, 1] * v + Hm[2, 2]
mx = ((Hm[0, 0] * u + Hm[0, 1] * v + Hm[0, 2]) / den).astype(np.float32)
my = ((Hm[1, 0] * u + Hm[1, 1] * v + Hm[1, 2]) / den).astype(np.float32)
band = slice(36, 48)
mx[band] = (rng.random((12, w)) * (W + 12) - 6).astype(np.float32)
my[band] = (rng.random((12, w)) * (H + 12) - 6).astype(np.float32)
m1, m2 = cv2.convertMaps(mx, my, cv2.CV_16SC2)
np.save(os.path.join(out, "map_x.npy"), m1[..., 0].copy())
np.save(os.path.join(out, "map_y.npy"), m1[..., 1].copy())
np.save(os.path.join(out, "map_frac.npy"), m2)
np.save(os.path.join(out, "src_u8.npy"), src8)
np.save(os.path.join(out, "src_u16.npy"), src16)
for name, src, full in [("u8", src8, 255), ("u16", src16, 65535)]:
    for interp, flag in [("linear", cv2.INTER_LINEAR), ("cubic", cv2.INTER_CUBIC)]:
        for border, mode, value in [("constant0", cv2.BORDER_CONSTANT, 0),
                                    ("constant", cv2.BORDER_CONSTANT, full // 3),
                                    ("replicate", cv2.BORDER_REPLICATE, 0)]:
            r = cv2.remap(src, m1, m2, flag, borderMode=mode, borderValue=value)
            np.save(os.path.join(out, f"out_{name}_{interp}_{border}.npy"), r)
with open(os.path.join(out, "versions.txt"), "w") as f:
    f.write(f"opencv {cv2.__version__}\nnumpy {np.__version__}\npython {sys.version.split()[0]}\n")
print("wrote", out)
