#!/usr/bin/env python3
"""OpenCV baseline for the rescale benchmark and exactness check (never part of CI).

Needs `pip install opencv-python-headless numpy`. Times cv2.resize single-threaded on the same
synthetic frames as fusion-engine/benches/rescale.rs (median of many runs), and, with
--check FUSION_BIN, compares `fusion rescale` output with cv2 pixel by pixel on the VIFB photos
and on 512²/1024² frames.
"""
import argparse, os, subprocess, sys, tempfile, time
import cv2
import numpy as np

def frame(w, h):
    i = np.arange(w * h, dtype=np.uint64)
    v = (i % w) * 7 + (i // w) * 13 + (i * 2654435761) % 31
    return (v % 256).astype(np.uint8).reshape(h, w)

def median_ms(fn, reps=300):
    for _ in range(20):
        fn()
    ts = []
    for _ in range(reps):
        t0 = time.perf_counter_ns(); fn(); ts.append(time.perf_counter_ns() - t0)
    return float(np.median(ts)) / 1e6

def timing():
    cv2.setNumThreads(1)
    tir, vis = frame(512, 512), frame(1024, 1024)
    rows = [
        ("cubic_512_to_1024", lambda: cv2.resize(tir, (1024, 1024), interpolation=cv2.INTER_CUBIC)),
        ("area_1024_to_512", lambda: cv2.resize(vis, (512, 512), interpolation=cv2.INTER_AREA)),
        ("cubic_1024_to_512", lambda: cv2.resize(vis, (512, 512), interpolation=cv2.INTER_CUBIC)),
        ("area_512_to_1024", lambda: cv2.resize(tir, (1024, 1024), interpolation=cv2.INTER_AREA)),
        ("memcpy_1024", lambda: vis.copy()),
    ]
    print(f"# cv2 {cv2.__version__}, IPP {cv2.ipp.useIPP()}, threads {cv2.getNumThreads()}")
    for name, fn in rows:
        print(f"{name}\t{median_ms(fn):.4f} ms")

def check(fusion_bin, data_dir):
    inputs = []
    for name in sorted(os.listdir(data_dir)):
        if name.endswith(("_VIS.png", "_IR.png")):
            inputs.append(cv2.imread(os.path.join(data_dir, name), cv2.IMREAD_UNCHANGED))
    rng = np.random.default_rng(0)
    inputs += [rng.integers(0, 256, (512, 512), dtype=np.uint8), rng.integers(0, 256, (1024, 1024), dtype=np.uint8),
               rng.integers(0, 256, (333, 517), dtype=np.uint8), frame(1024, 1024)]
    total = bad = 0
    with tempfile.TemporaryDirectory() as d:
        src_p, out_p = os.path.join(d, "in.png"), os.path.join(d, "out.png")
        for img in inputs:
            h, w = img.shape
            cv2.imwrite(src_p, img)
            for interp, flag in (("cubic", cv2.INTER_CUBIC), ("area", cv2.INTER_AREA)):
                for (dw, dh) in ((2 * w, 2 * h), (w // 2, h // 2)):
                    if (dw, dh) == (w // 2, h // 2) and (w % 2 or h % 2):
                        continue  # not an exact 2x ratio
                    subprocess.run([fusion_bin, "rescale", "--filter", interp, "--width", str(dw), "--height", str(dh),
                                    src_p, out_p], check=True)
                    ours = cv2.imread(out_p, cv2.IMREAD_UNCHANGED)
                    ref = cv2.resize(img, (dw, dh), interpolation=flag)
                    n = int(np.count_nonzero(ours != ref)); total += ref.size; bad += n
                    print(f"{w}x{h} -> {dw}x{dh} {interp}: {n} differing pixels")
    print(f"total: {bad} of {total} pixels differ")
    return bad

if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--check", metavar="FUSION_BIN")
    ap.add_argument("--data", default=os.path.join(os.path.dirname(__file__), "../tests/data/vifb"))
    a = ap.parse_args()
    if a.check:
        sys.exit(1 if check(a.check, a.data) else 0)
    timing()
