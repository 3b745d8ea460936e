#!/usr/bin/env python3
"""Writes libjpeg's decodes of the repository's JPEGs as PNGs: tests/data/vifb_jpeg/libjpeg/.

Needs `pip install pillow numpy` (Pillow bundles libjpeg-turbo; its default decode is libjpeg's:
the integer "islow" IDCT, fancy chroma upsampling, libjpeg's YCbCr->RGB). A 3-component JPEG is
written as RGB, a 1-component one as L (grey), as MATLAB's imread, OpenCV and Pillow return them.
If OpenCV is installed (`opencv-python-headless`, its own libjpeg-turbo), its decode must give the
same bytes, or nothing is written.

    python3 scripts/libjpeg_reference_decodes.py            # writes the six PNGs
    python3 scripts/libjpeg_reference_decodes.py --check    # compares, writes nothing

`fusion-io/tests/jpeg_libjpeg.rs` decodes each JPEG with fusion-io and compares with these PNGs.
"""
import argparse, hashlib, io, os, sys
import numpy as np
from PIL import Image, features

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "data", "vifb_jpeg")
NAMES = ["fight", "manWalking", "walkingnight"]


def decode(path):
    with Image.open(path) as im:
        if im.format != "JPEG" or im.mode not in ("L", "RGB"):
            sys.exit(f"{path}: a {im.format} {im.mode} image; expected an 8-bit grey or YCbCr JPEG")
        im.load()
        return im.copy()


def opencv_agrees(path, im):
    try:
        import cv2
    except ImportError:
        return None
    a = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if a.ndim == 3:
        a = a[:, :, ::-1]  # BGR -> RGB
    return np.array_equal(a, np.asarray(im))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="compare with the committed PNGs; write nothing")
    args = ap.parse_args()
    print(f"Pillow {Image.__version__}, libjpeg-turbo {features.version('libjpeg_turbo')}")
    out_dir = os.path.join(ROOT, "libjpeg")
    os.makedirs(out_dir, exist_ok=True)
    bad = 0
    for band in ["VI", "IR"]:
        for name in NAMES:
            src = os.path.join(ROOT, band, f"{name}.jpg")
            im = decode(src)
            cv = opencv_agrees(src, im)
            if cv is False:
                sys.exit(f"{src}: OpenCV's decode differs from Pillow's; not writing references")
            png = os.path.join(out_dir, f"{band}_{name}.png")
            raw = np.asarray(im).tobytes()
            line = f"{band}/{name}.jpg {im.mode} {im.size[0]}x{im.size[1]} sha256 {hashlib.sha256(raw).hexdigest()[:16]}"
            line += "" if cv is None else " (= OpenCV)"
            if args.check:
                with Image.open(png) as ref:
                    same = ref.mode == im.mode and np.array_equal(np.asarray(ref), np.asarray(im))
                bad += not same
                print(f"{line}: {'same' if same else 'DIFFERS from'} {png}")
            else:
                buf = io.BytesIO()
                im.save(buf, format="PNG", optimize=True)
                with open(png, "wb") as f:
                    f.write(buf.getvalue())
                print(f"{line} -> {os.path.relpath(png)}")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
