"""vistir against the `fusion` CLI it shares its code with: the same bytes and numbers for every
method, variant, rescale and skip policy, strips, colour, 16-bit thermal counts, the rescalers
and the metrics; the error cases; arrays read in place with any row stride.

The CLI is `$FUSION_BIN`, else `target/release/fusion` of the repository (build it with
`cargo build --release -p host-harness --bin fusion`).
"""

import json
import math
import os
import subprocess
import threading
from pathlib import Path

import numpy as np
import pytest
import vistir

REPO = Path(__file__).resolve().parents[2]
FUSION = Path(os.environ.get("FUSION_BIN", REPO / "target" / "release" / "fusion"))
PGM = REPO / "fusion-ffi" / "examples" / "data"
VIFB = REPO / "tests" / "data" / "vifb"
JPEG = REPO / "tests" / "data" / "vifb_jpeg"
METHODS = ["adf", "tsifsd", "ifevip", "adaptive"]
VARIANTS = ["flight", "classic"]


def fusion(*args):
    """Runs the CLI; returns its standard output."""
    if not FUSION.exists():
        pytest.fail(f"the fusion CLI is not at {FUSION}: build it or set FUSION_BIN")
    done = subprocess.run([str(FUSION), *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


def cli_fuse(tmp_path, vis, tir, *options):
    out = tmp_path / "cli.png"
    fusion("fuse", *options, vis, tir, out)
    return vistir.load(out)


@pytest.fixture(scope="module")
def pair():
    return vistir.load(PGM / "vis_256.pgm"), vistir.load(PGM / "tir_128.pgm")


def test_the_inputs_load_as_uint8_grey(pair):
    vis, tir = pair
    assert (vis.dtype, vis.shape, tir.shape) == (np.uint8, (256, 256), (128, 128))


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("variant", VARIANTS)
@pytest.mark.parametrize("rescale", ["tir-up", "vis-down"])
def test_fuse_gives_the_cli_bytes(tmp_path, pair, method, variant, rescale):
    vis, tir = pair
    got = vistir.fuse(vis, tir, method=method, variant=variant, rescale=rescale)
    expected = cli_fuse(
        tmp_path, PGM / "vis_256.pgm", PGM / "tir_128.pgm", "--method", method, "--variant", variant, "--rescale", rescale
    )
    assert got.dtype == np.uint8 and got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)


@pytest.mark.parametrize("method", ["adf", "tsifsd", "ifevip"])
def test_a_real_vifb_pair_gives_the_cli_bytes(tmp_path, method):
    vis, tir = VIFB / "kettle_VIS.png", VIFB / "kettle_IR.png"
    got = vistir.fuse(vistir.load(vis), vistir.load(tir), method=method, rescale="none")
    np.testing.assert_array_equal(got, cli_fuse(tmp_path, vis, tir, "--method", method, "--rescale", "none"))


@pytest.mark.parametrize("method", METHODS)
def test_strips_and_skipping_give_the_cli_bytes(tmp_path, pair, method):
    vis, tir = pair
    vp, tp = PGM / "vis_256.pgm", PGM / "tir_128.pgm"
    whole = vistir.fuse(vis, tir, method=method)
    strips = vistir.fuse(vis, tir, method=method, strips=16)
    np.testing.assert_array_equal(strips, whole)
    np.testing.assert_array_equal(strips, cli_fuse(tmp_path, vp, tp, "--method", method, "--strips", "16"))
    for skip in ["roi", "all"]:
        got, report = vistir.fuse(vis, tir, method=method, skip=skip, report=True)
        np.testing.assert_array_equal(got, cli_fuse(tmp_path, vp, tp, "--method", method, "--skip", skip))
        assert report["grid"] == (256, 256) and report["rescaled"] is True


@pytest.mark.parametrize("method", METHODS)
def test_a_caller_window_gives_the_cli_bytes(tmp_path, pair, method):
    vis, tir = pair
    vp, tp = PGM / "vis_256.pgm", PGM / "tir_128.pgm"
    got, report = vistir.fuse(vis, tir, method=method, window=(40, 60, 200, 180), report=True)
    np.testing.assert_array_equal(got, cli_fuse(tmp_path, vp, tp, "--method", method, "--window", "40,60,200,180"))
    assert report["skip_taken"] & 1 and report["skip_declined"] is None
    with pytest.raises(ValueError, match="not both"):
        vistir.fuse(vis, tir, method=method, skip="roi", window=(0, 0, 8, 8))
    with pytest.raises(ValueError, match="empty"):
        vistir.fuse(vis, tir, method=method, window=(8, 0, 8, 8))


def test_colour_visible_gives_the_cli_rgb(tmp_path):
    vis, tir = JPEG / "VI" / "fight.jpg", JPEG / "IR" / "fight.jpg"
    v = vistir.load(vis)
    assert v.ndim == 3 and v.shape[2] == 3
    got = vistir.fuse(v, vistir.load(tir), method="tsifsd", rescale="none")
    expected = cli_fuse(tmp_path, vis, tir, "--method", "tsifsd", "--rescale", "none")
    assert got.shape == expected.shape == v.shape
    np.testing.assert_array_equal(got, expected)


def thermal_counts(w, h):
    """14-bit counts: a cold background with noise, a warm block with a gradient."""
    rng = np.random.default_rng(7)
    counts = 3000 + rng.integers(0, 40, size=(h, w))
    counts[h // 3 : 2 * h // 3, w // 4 : 3 * w // 4] += 5000 + np.arange(w // 2)[None, :] * 8
    return counts.astype(np.uint16)


@pytest.mark.parametrize("agc", [[], ["--agc", "plateau"], ["--agc", "plateau", "--plateau", "3"]])
def test_16_bit_thermal_counts_go_through_the_cli_agc(tmp_path, pair, agc):
    vis, _ = pair
    counts = thermal_counts(128, 128)
    path = tmp_path / "tir16.png"
    vistir.save(path, counts)
    np.testing.assert_array_equal(vistir.load(path), counts)
    kwargs = {}
    if agc:
        kwargs["agc"] = "plateau"
    if "--plateau" in agc:
        kwargs["plateau"] = 3
    got = vistir.fuse(vis, counts, method="adf", **kwargs)
    np.testing.assert_array_equal(got, cli_fuse(tmp_path, PGM / "vis_256.pgm", path, "--method", "adf", *agc))


def test_rows_with_any_stride_and_non_contiguous_arrays_give_the_same_bytes(pair):
    vis, tir = pair
    expected = vistir.fuse(vis, tir, method="adf")
    padded = np.zeros((256, 300), np.uint8)
    padded[:, :256] = vis
    in_place = padded[:, :256]  # rows 300 bytes apart: read in place
    assert not in_place.flags.c_contiguous
    np.testing.assert_array_equal(vistir.fuse(in_place, tir, method="adf"), expected)
    transposed = np.ascontiguousarray(vis.T).T  # column-major: copied
    np.testing.assert_array_equal(vistir.fuse(transposed, tir, method="adf"), expected)
    stepped = np.repeat(tir, 2, axis=1)[:, ::2]  # every other column: copied
    np.testing.assert_array_equal(vistir.fuse(vis, stepped, method="adf"), expected)
    assert np.array_equal(padded[:, 256:], np.zeros((256, 44), np.uint8)), "an input was written"


@pytest.mark.parametrize("filter", ["cubic", "area"])
@pytest.mark.parametrize("size", [(512, 512), (100, 70)])
def test_rescale_gives_the_cli_bytes_for_8_and_16_bits(tmp_path, pair, filter, size):
    vis, _ = pair
    w, h = size
    out = tmp_path / "r.png"
    fusion("rescale", "--width", w, "--height", h, "--filter", filter, PGM / "vis_256.pgm", out)
    got = vistir.rescale(vis, w, h, filter=filter)
    assert got.shape == (h, w)
    np.testing.assert_array_equal(got, vistir.load(out))
    counts = thermal_counts(128, 96)
    path16 = tmp_path / "c.png"
    vistir.save(path16, counts)
    fusion("rescale", "--width", w, "--height", h, "--filter", filter, path16, out)
    got16 = vistir.rescale(counts, w, h, filter=filter)
    assert got16.dtype == np.uint16
    np.testing.assert_array_equal(got16, vistir.load(out))


def same_number(a, b):
    return (math.isnan(a) and math.isnan(b)) or a == b


@pytest.mark.parametrize("suite", ["vifb", "study", "all"])
def test_eval_gives_the_cli_numbers(tmp_path, suite):
    vis, tir = JPEG / "VI" / "manWalking.jpg", JPEG / "IR" / "manWalking.jpg"
    fused_path = tmp_path / "f.png"
    fusion("fuse", "--method", "adf", vis, tir, fused_path)
    got = vistir.eval(vistir.load(vis), vistir.load(tir), vistir.load(fused_path), suite=suite)
    cli = json.loads(fusion("eval", "--suite", suite, "--format", "json", vis, tir, fused_path))
    if suite == "all":  # nested in JSON, prefixed in the dict (the CSV header's names)
        cli = {f"{group}.{k}": v for group, values in cli.items() for k, v in values.items()}
    assert list(got) == list(cli)
    for name, value in cli.items():
        assert same_number(got[name], float("nan") if value is None else value), name


def test_bad_input_raises_a_one_line_error(pair, tmp_path):
    vis, tir = pair
    with pytest.raises(TypeError, match="uint8"):
        vistir.fuse(vis.astype(np.float32), tir)
    with pytest.raises(TypeError, match="uint8"):
        vistir.fuse(vis, np.zeros((4, 4, 4), np.uint8))
    with pytest.raises(ValueError, match="adf, tsifsd, ifevip, adaptive"):
        vistir.fuse(vis, tir, method="fft")
    with pytest.raises(ValueError, match="tir-up, vis-down, none"):
        vistir.fuse(vis, tir, rescale="up")
    with pytest.raises(ValueError, match="does not match"):
        vistir.fuse(vis, tir, rescale="none")
    with pytest.raises(ValueError, match="16-bit"):
        vistir.fuse(thermal_counts(256, 256), tir)
    with pytest.raises(ValueError, match="strips"):
        vistir.fuse(vis, tir, strips=0)
    with pytest.raises(ValueError, match="plateau"):
        vistir.fuse(vis, thermal_counts(128, 128), plateau=4)
    with pytest.raises(ValueError, match="zero"):
        vistir.rescale(vis, 0, 10)
    with pytest.raises(ValueError, match="cubic, area"):
        vistir.rescale(vis, 10, 10, filter="lanczos")
    with pytest.raises(ValueError, match=r"\.png"):
        vistir.save(tmp_path / "x.jpg", vis)
    assert not (tmp_path / "x.jpg").exists()
    with pytest.raises(OSError):
        vistir.load(tmp_path / "missing.png")
    for e in [TypeError, ValueError]:
        try:
            vistir.fuse(vis, tir, method="fft") if e is ValueError else vistir.fuse(vis.astype(np.int16), tir)
        except e as caught:
            assert "\n" not in str(caught)


def test_threads_fuse_at_once_with_the_same_results(pair):
    vis, tir = pair
    expected = {m: vistir.fuse(vis, tir, method=m) for m in METHODS}
    results, errors = {}, []

    def work(i):
        try:
            m = METHODS[i % len(METHODS)]
            results[i] = (m, vistir.fuse(vis, tir, method=m))
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for m, got in results.values():
        np.testing.assert_array_equal(got, expected[m])


def test_render_writes_a_dataset_and_returns_its_manifest(tmp_path):
    out = tmp_path / "ds"
    manifest = vistir.render(out, frames=2, vis_size=128, tir_sizes=[64])
    on_disk = json.loads((out / "manifest.json").read_text())
    assert manifest == on_disk
    assert manifest["seed"] == 1
    pngs = sorted(p.relative_to(out) for p in out.rglob("*.png"))
    assert pngs, "no frames written"
    first = {p: (out / p).read_bytes() for p in pngs}
    again = vistir.render(out, frames=2, vis_size=128, tir_sizes=[64])  # into the same folder
    assert again == manifest, "same seed, same manifest"
    assert all((out / p).read_bytes() == b for p, b in first.items()), "same seed, same frames"
    with pytest.raises(ValueError, match="approach"):
        vistir.render(tmp_path / "x", sequence="orbit")
    # The second target: named in the manifest, other pixels than the first's.
    boxwing = vistir.render(tmp_path / "bw", frames=2, vis_size=128, tir_sizes=[64], target="boxwing")
    assert boxwing["target"] == "boxwing"
    assert (tmp_path / "bw" / pngs[0]).read_bytes() != first[pngs[0]]
    with pytest.raises(ValueError, match="boxwing"):
        vistir.render(tmp_path / "y", target="hubble")


def test_the_gil_is_released_while_the_core_runs():
    """Another Python thread takes steps in the middle of a fusion call. With the GIL held it
    could not: at most a switch interval (5 ms) of steps slips in just before the call enters
    the core or just after it returns, never in the middle half of a call of tens of ms."""
    import time

    rng = np.random.default_rng(3)
    # 2048² so that a call lasts tens of ms even on a fast core (1024² ADF took < 20 ms here
    # in one run of the suite, which left nothing to judge).
    vis = rng.integers(0, 256, size=(2048, 2048), dtype=np.uint8)
    tir = rng.integers(0, 256, size=(1024, 1024), dtype=np.uint8)
    stamps, stop = [], threading.Event()

    def spin():
        while not stop.is_set():
            stamps.append(time.perf_counter())

    spinner = threading.Thread(target=spin)
    spinner.start()
    inside = []
    try:
        for _ in range(5):
            t0 = time.perf_counter()
            vistir.fuse(vis, tir, method="adf")
            t1 = time.perf_counter()
            quarter = (t1 - t0) / 4
            if t1 - t0 > 0.02:
                inside.append(sum(t0 + quarter < t < t1 - quarter for t in stamps))
    finally:
        stop.set()
        spinner.join()
    assert inside, "every call was too short to judge"
    assert max(inside) > 0, inside


@pytest.fixture(scope="module")
def raw_sequence(tmp_path_factory):
    """A two-frame sequence with the thermal camera's raw counts and calibration."""
    out = tmp_path_factory.mktemp("raw") / "seq"
    fusion("render", "--sequence", "flyaround", "--frames", "2", "--vis-size", "128",
           "--tir-sizes", "64", "--samples", "1", "--raw-tir", "--out", out)
    return out


@pytest.mark.parametrize("column", [None, 900, "auto"])
def test_correct_thermal_gives_the_cli_bytes(tmp_path, raw_sequence, column):
    seq = raw_sequence
    nuc, bad = seq / "calibration" / "tir.nuc", seq / "calibration" / "tir_bad_pixels.png"
    raw, shutter = vistir.load(seq / "tir_raw" / "frame_001.png"), vistir.load(seq / "tir_raw" / "frame_000.png")
    assert raw.dtype == np.uint16
    kwargs = {} if column is None else {"column_filter": column}
    corrected = vistir.correct_thermal(raw, nuc=nuc, bad_pixels=bad, shutter=shutter, **kwargs)
    assert corrected.dtype == np.uint16 and corrected.shape == raw.shape
    assert not np.array_equal(corrected, raw)
    options = ["--nuc", nuc, "--bad-pixels", bad, "--shutter", seq / "tir_raw" / "frame_000.png"]
    if column is not None:
        options += ["--column-filter", column]
    vis = vistir.load(seq / "vis" / "frame_001.png")
    got = vistir.fuse(vis, corrected, method="tsifsd")
    want = cli_fuse(tmp_path, seq / "vis" / "frame_001.png", seq / "tir_raw" / "frame_001.png",
                    "--method", "tsifsd", *options)
    np.testing.assert_array_equal(got, want)


def test_correct_thermal_refuses_bad_calibration(tmp_path, raw_sequence):
    raw = vistir.load(raw_sequence / "tir_raw" / "frame_000.png")
    with pytest.raises(ValueError, match="VISTNUC1"):
        vistir.correct_thermal(raw, nuc=raw_sequence / "vis" / "frame_000.png")
    with pytest.raises(ValueError, match="nuc="):
        vistir.correct_thermal(raw, shutter=raw)
    with pytest.raises(ValueError, match="column_filter"):
        vistir.correct_thermal(raw, column_filter="often")
    with pytest.raises(ValueError, match="64x64"):
        vistir.correct_thermal(raw[:32], nuc=raw_sequence / "calibration" / "tir.nuc")


RIG = REPO / "tests" / "data" / "rig" / "offset_rig.json"


@pytest.mark.parametrize("interp", ["linear", "cubic"])
@pytest.mark.parametrize("bits", [8, 16])
def test_register_gives_the_cli_bytes(tmp_path, interp, bits):
    tir = thermal_counts(512, 512)
    if bits == 8:
        tir = (tir >> 6).astype(np.uint8)
    src, out = tmp_path / "tir.png", tmp_path / "reg.png"
    vistir.save(src, tir)
    fusion("register", "--rig", RIG, "--range", "8", "--interp", interp, src, out)
    got = vistir.register(tir, rig=RIG, range=8.0, interp=interp)
    assert got.dtype == tir.dtype and got.shape == (1024, 1024)
    np.testing.assert_array_equal(got, vistir.load(out))
    # The thermal camera's wider field covers the visible grid; the rig moves the frame.
    assert np.count_nonzero(got) > 1024 * 1024 // 2
    assert not np.array_equal(got, vistir.rescale(tir, 1024, 1024))


def test_register_refuses_bad_input(tmp_path):
    tir = np.zeros((512, 512), np.uint8)
    with pytest.raises(ValueError, match="512x512"):
        vistir.register(tir[:100], rig=RIG, range=8.0)
    with pytest.raises(ValueError, match="range"):
        vistir.register(tir, rig=RIG, range=-1.0)
    with pytest.raises(ValueError, match="interp"):
        vistir.register(tir, rig=RIG, range=8.0, interp="lanczos")
    bad = tmp_path / "rig.json"
    bad.write_text('{"R": 1}')
    with pytest.raises(ValueError, match="camera_matrix_vis"):
        vistir.register(tir, rig=bad, range=8.0)


@pytest.mark.parametrize("strips", [None, 24])
def test_a_sequence_gives_the_cli_sequence_mode_bytes(tmp_path, strips):
    """vistir.Sequence over rendered fly-around frames = `fusion fuse --sequence-mode` on their
    folders (name order), whole frame and in strips; the first frame is `vistir.fuse`'s, the
    later ones carry the previous frame's weight; reset() starts afresh."""
    seq_dir = tmp_path / "seq"
    fusion("--quiet", "render", "--sequence", "flyaround", "--frames", "6", "--vis-size", "128", "--tir-sizes", "64", "--out", seq_dir)
    options = ["--method", "adf", "--sequence-mode"] + (["--strips", str(strips)] if strips else [])
    fusion("--quiet", "fuse", *options, seq_dir / "vis", seq_dir / "tir", tmp_path / "out")
    names = sorted(p.name for p in (seq_dir / "vis").iterdir())
    seq = vistir.Sequence("adf", strips=strips)
    previous_own = None
    for k, name in enumerate(names):
        vis, tir = vistir.load(seq_dir / "vis" / name), vistir.load(seq_dir / "tir" / name)
        got, report = seq.fuse(vis, tir, report=True)
        np.testing.assert_array_equal(got, vistir.load(tmp_path / "out" / (Path(name).stem + ".png")))
        if k == 0:
            assert (report["pass"], report["restart"]) == ("own", "first")
            np.testing.assert_array_equal(got, vistir.fuse(vis, tir, method="adf"))
        elif report["pass"] == "carried":
            assert report["p_ir_used"] == previous_own
        previous_own = report["p_ir_own"]
    seq.reset()
    vis, tir = vistir.load(seq_dir / "vis" / names[0]), vistir.load(seq_dir / "tir" / names[0])
    assert seq.fuse(vis, tir, report=True)[1]["pass"] == "own"
    with pytest.raises(ValueError, match="size_change_percent"):
        vistir.Sequence("adf", size_change_percent=99)
    with pytest.raises(ValueError, match="strips"):
        vistir.Sequence("adf", skip="roi", strips=8)
