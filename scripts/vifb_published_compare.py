#!/usr/bin/env python3
"""`fusion eval --suite vifb` against VIFB's published per-image metric values (docs/vifb-published.md).

VIFB (github.com/xingchenzhang/VIFB) publishes, in `output/`, the fused images of 25 methods on
its 21 pairs (`fused_images/PAIR_METHOD.jpg`, colour) and the values its MATLAB code computed on
them, one file per value (`evaluation_metrics_single/PAIR_METHOD_METRIC.txt`, 5 significant
digits; `evaluation_metrics/evaluationMetrics.mat` holds the same rounded numbers). This script
runs the CLI as a new user would — `fusion eval --suite vifb --format csv input/VI input/IR
FUSED/` with one folder of fused images per method (links named PAIR.jpg) — and prints, per
metric, the median, 95th percentile and worst relative difference |ours − published| / |published|
over all triples, and the worst triples.

    python3 scripts/vifb_published_compare.py --vifb VIFB_CHECKOUT --fusion target/release/fusion \
        [--csv ours.csv] [--worst 5]

Needs Python 3 only (no packages). Nothing is written but the optional --csv.
"""
import argparse, csv, io, math, os, subprocess, sys, tempfile

# fusion's key -> VIFB's metric file name.
METRICS = {
    "AG": "Avg_gradient", "CE": "Cross_entropy", "EI": "Edge_intensity", "EN": "Entropy",
    "MI": "Mutinf", "PSNR": "Psnr", "Qabf": "Qabf", "Qcb": "Qcb", "Qcv": "Qcv", "RMSE": "Rmse",
    "SF": "Spatial_frequency", "SSIM": "Ssim", "SD": "Variance",
}


def quantile(sorted_values, q):
    """Linear interpolation between order statistics (numpy's default)."""
    if not sorted_values:
        return math.nan
    pos = q * (len(sorted_values) - 1)
    lo = math.floor(pos)
    hi = min(lo + 1, len(sorted_values) - 1)
    return sorted_values[lo] + (sorted_values[hi] - sorted_values[lo]) * (pos - lo)


def triples(vifb):
    pairs = sorted(os.path.splitext(f)[0] for f in os.listdir(os.path.join(vifb, "input", "VI")))
    fused_dir = os.path.join(vifb, "output", "fused_images")
    by_method = {}
    for f in sorted(os.listdir(fused_dir)):
        stem, ext = os.path.splitext(f)
        # The longest pair name that prefixes the stem ("walking2_X" is not "walking_2_X").
        pair = max((p for p in pairs if stem.startswith(p + "_")), key=len, default=None)
        if pair is None:
            sys.exit(f"{f}: no pair name in input/VI prefixes it")
        by_method.setdefault(stem[len(pair) + 1:], []).append((pair, os.path.join(fused_dir, f)))
    return pairs, by_method


def published(vifb, pair, method, metric):
    """VIFB's single-value files name the method by its first part (HMSD_GF -> HMSD_…)."""
    d = os.path.join(vifb, "output", "evaluation_metrics_single")
    for m in (method, method.split("_")[0]):
        p = os.path.join(d, f"{pair}_{m}_{metric}.txt")
        if os.path.isfile(p):
            with open(p) as f:
                return float(f.read().strip())
    sys.exit(f"no published {metric} for {pair} {method} in {d}")


def run_fusion(fusion, vifb, method, files, tmp):
    folder = os.path.join(tmp, method)
    os.makedirs(folder)
    for pair, path in files:
        os.symlink(os.path.abspath(path), os.path.join(folder, pair + os.path.splitext(path)[1]))
    cmd = [fusion, "eval", "--suite", "vifb", "--format", "csv",
           os.path.join(vifb, "input", "VI"), os.path.join(vifb, "input", "IR"), folder]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{r.stderr}")
    rows = list(csv.DictReader(io.StringIO(r.stdout)))
    return {row["image"]: row for row in rows if row["row"] == "image"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vifb", required=True, help="a checkout of xingchenzhang/VIFB")
    ap.add_argument("--fusion", required=True, help="the fusion binary")
    ap.add_argument("--csv", help="write every (pair, method, metric, ours, published, rel) here")
    ap.add_argument("--worst", type=int, default=3, help="worst triples shown per metric")
    args = ap.parse_args()
    pairs, by_method = triples(args.vifb)
    n = sum(len(v) for v in by_method.values())
    print(f"{len(by_method)} methods, {len(pairs)} pairs, {n} fused images")
    records = []
    with tempfile.TemporaryDirectory() as tmp:
        for method, files in sorted(by_method.items()):
            ours = run_fusion(args.fusion, args.vifb, method, files, tmp)
            for pair, _ in files:
                for key, name in METRICS.items():
                    o = float(ours[pair][key])
                    p = published(args.vifb, pair, method, name)
                    rel = abs(o - p) / abs(p) if p != 0 else (0.0 if o == p else math.inf)
                    records.append((pair, method, key, o, p, rel))
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["pair", "method", "metric", "ours", "published", "relative"])
            w.writerows(records)
    print(f"\n| metric | n | median | p95 | worst | worst triple (ours / published) |")
    print("|---|---|---|---|---|---|")
    for key in METRICS:
        rs = sorted((r for r in records if r[2] == key), key=lambda r: r[5])
        rel = [r[5] for r in rs]
        w = rs[-1]
        print(f"| {key} | {len(rel)} | {quantile(rel, 0.5):.2e} | {quantile(rel, 0.95):.2e} | {rel[-1]:.2e} "
              f"| {w[0]} {w[1]} ({w[3]:.6g} / {w[4]:.6g}) |")
    if args.worst:
        print("\nworst triples per metric:")
        for key in METRICS:
            rs = sorted((r for r in records if r[2] == key), key=lambda r: -r[5])[:args.worst]
            print(f"  {key}: " + "; ".join(f"{r[0]} {r[1]} {r[3]:.6g}/{r[4]:.6g} ({r[5]:.1e})" for r in rs))


if __name__ == "__main__":
    main()
