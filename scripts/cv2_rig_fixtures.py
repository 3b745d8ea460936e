#!/usr/bin/env python3
"""OpenCV's view of the default offset rig, for the registration map tests.

Needs `pip install opencv-python-headless numpy`. Writes into tests/data/rig/:
* offset_rig.yml, offset_rig.json: the rig through cv2.FileStorage (OpenCV's own YAML and JSON),
  keys camera_matrix_vis, dist_coeffs_vis, image_size_vis, the same with _tir, R, T;
* positions_<range>m.npy (range 5 and 20 m): for the visible pixels on a grid every 32 px (the last row and column at 1023)
  (33 x 33, float64, shape (33, 33, 2)), the thermal pixel each sees on the plane
  Z_vis = range: cv2.undistortPoints with criteria (200 iterations, eps 1e-15) to the normalised ray,
  the plane point range*(x, y, 1), cv2.projectPoints with rvec = Rodrigues(R), T and the
  thermal intrinsics and distortion;
* undistorted_<range>m.npy: the same rig with an ideal visible lens, by
  cv2.initUndistortRectifyMap(K_tir, D_tir, inv(H), K_vis, size_vis, CV_32FC1) with the
  plane-induced homography H = R + T (0, 0, 1) / range — the map on the same grid;
* versions.txt.
"""
import os, sys
import cv2
import numpy as np

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "rig")
os.makedirs(out, exist_ok=True)

def K(f, c):
    return np.array([[f, 0, c[0]], [0, f, c[1]], [0, 0, 1]], dtype=np.float64)

# VIS 1024^2, 30 deg; TIR 512^2, 35 deg; the thermal camera 0.2 m to the right, toed in 0.4 deg.
K_vis = K(512 / np.tan(np.radians(15)), (511.5, 511.5))
K_tir = K(256 / np.tan(np.radians(17.5)), (255.5, 255.5))
D_vis = np.array([-0.08, 0.02, 0.0004, -0.0003, 0.0], dtype=np.float64)
D_tir = np.array([-0.15, 0.05, 0.0008, 0.0005, -0.004], dtype=np.float64)
R, _ = cv2.Rodrigues(np.radians(np.array([0.15, -0.4, 0.1])))
T = np.array([-0.2, 0.01, 0.005], dtype=np.float64)   # X_tir = R X_vis + T: TIR 0.2 m to +x
size_vis, size_tir = (1024, 1024), (512, 512)

for ext, fmt in [("yml", cv2.FILE_STORAGE_WRITE), ("json", cv2.FILE_STORAGE_WRITE)]:
    fs = cv2.FileStorage(os.path.join(out, f"offset_rig.{ext}"), fmt)
    fs.write("camera_matrix_vis", K_vis); fs.write("dist_coeffs_vis", D_vis.reshape(1, 5))
    fs.write("image_size_vis", np.array(size_vis, dtype=np.int32).reshape(1, 2))
    fs.write("camera_matrix_tir", K_tir); fs.write("dist_coeffs_tir", D_tir.reshape(1, 5))
    fs.write("image_size_tir", np.array(size_tir, dtype=np.int32).reshape(1, 2))
    fs.write("R", R); fs.write("T", T.reshape(3, 1))
    fs.release()

grid = np.arange(0, 1025, 32, dtype=np.float64)
grid[-1] = 1023
gu, gv = np.meshgrid(grid, grid)
pts = np.stack([gu, gv], -1).reshape(-1, 1, 2)
crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)
rays = cv2.undistortPoints(pts, K_vis, D_vis, R=np.eye(3), P=np.eye(3), criteria=crit).reshape(-1, 2)
rvec, _ = cv2.Rodrigues(R)
for rng_m in (5, 20):
    X = np.concatenate([rays * rng_m, np.full((len(rays), 1), float(rng_m))], 1)
    p, _ = cv2.projectPoints(X, rvec, T, K_tir, D_tir)
    np.save(os.path.join(out, f"positions_{rng_m}m.npy"), p.reshape(len(grid), len(grid), 2))
    Hh = R + T.reshape(3, 1) @ np.array([[0.0, 0.0, 1.0 / rng_m]])
    mx, my = cv2.initUndistortRectifyMap(K_tir, D_tir, np.linalg.inv(Hh), K_vis, size_vis, cv2.CV_32FC1)
    gi = grid.astype(int)
    np.save(os.path.join(out, f"undistorted_{rng_m}m.npy"),
            np.stack([mx[np.ix_(gi, gi)], my[np.ix_(gi, gi)]], -1).astype(np.float64))
with open(os.path.join(out, "versions.txt"), "w") as f:
    f.write(f"opencv {cv2.__version__}\nnumpy {np.__version__}\npython {sys.version.split()[0]}\n")
print("wrote", out)
