//! Issue 9, the CLI side: missing, empty, corrupt and truncated PNGs, colour, palette, 1-bit
//! and 16-bit PNGs, frames over the core's capacity, impossible output sizes and unwritable
//! output paths. Each failure exits with status 1 and exactly one line on stderr (no panic, no
//! backtrace), and leaves no output file and no temporary file behind; each accepted image is
//! converted to 8-bit grey as documented.

use fusion_io::{ColorPolicy, Gray, load_gray_u8, save_gray_u8};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fusion(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fusion")).args(args).output().expect("run fusion")
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap()
}

/// Exit status 1, one line on stderr mentioning `needle`, no panic.
#[track_caller]
fn assert_clean_failure(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "exit status; stderr: {err}");
    assert_eq!(err.lines().count(), 1, "one-line error, got: {err}");
    assert!(err.starts_with("fusion: error: "), "{err}");
    assert!(err.to_lowercase().contains(&needle.to_lowercase()), "error {err:?} should mention {needle:?}");
    assert!(!err.contains("panicked") && !err.contains("backtrace"), "{err}");
}

/// The files of `dir` other than `keep`.
fn extra_files(dir: &Path, keep: &[&Path]) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|f| !keep.iter().any(|k| k == f))
        .collect()
}

// A minimal PNG writer (stored deflate blocks), for the colour types the `image` encoder does
// not write (palette, 1-bit) and for hand-made headers.

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= u32::from(b);
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

fn chunk(out: &mut Vec<u8>, kind: &[u8; 4], data: &[u8]) {
    out.extend_from_slice(&(data.len() as u32).to_be_bytes());
    let mut body = kind.to_vec();
    body.extend_from_slice(data);
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32(&body).to_be_bytes());
}

fn zlib_stored(data: &[u8]) -> Vec<u8> {
    let mut z = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = if data.is_empty() { vec![&[][..]] } else { data.chunks(65535).collect() };
    for (i, block) in blocks.iter().enumerate() {
        z.push(u8::from(i + 1 == blocks.len()));
        let n = block.len() as u16;
        z.extend_from_slice(&n.to_le_bytes());
        z.extend_from_slice(&(!n).to_le_bytes());
        z.extend_from_slice(block);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &v in data {
        a = (a + u32::from(v)) % 65521;
        b = (b + a) % 65521;
    }
    z.extend_from_slice(&((b << 16) | a).to_be_bytes());
    z
}

/// A PNG of `w × h` with the given colour type and bit depth; `rows` are the raw scanlines
/// (without the filter byte); `plte` for palette images.
fn png(w: u32, h: u32, color_type: u8, depth: u8, rows: &[Vec<u8>], plte: Option<&[u8]>) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[depth, color_type, 0, 0, 0]);
    chunk(&mut out, b"IHDR", &ihdr);
    if let Some(plte) = plte {
        chunk(&mut out, b"PLTE", plte);
    }
    let raw: Vec<u8> = rows.iter().flat_map(|r| std::iter::once(0u8).chain(r.iter().copied())).collect();
    chunk(&mut out, b"IDAT", &zlib_stored(&raw));
    chunk(&mut out, b"IEND", &[]);
    out
}

/// A textured 8-bit grey frame.
fn frame(w: usize, h: usize) -> Gray<u8> {
    Gray { width: w, height: h, data: (0..w * h).map(|i| ((i * 37) % 251) as u8).collect() }
}

struct Setup {
    dir: tempfile::TempDir,
    vis: PathBuf,
    tir: PathBuf,
    out: PathBuf,
}

fn setup() -> Setup {
    let dir = tempfile::tempdir().unwrap();
    let (vis, tir, out) =
        (dir.path().join("vis.png"), dir.path().join("tir.png"), dir.path().join("out.png"));
    save_gray_u8(&vis, &frame(16, 12)).unwrap();
    save_gray_u8(&tir, &frame(8, 6)).unwrap();
    Setup { dir, vis, tir, out }
}

impl Setup {
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }

    /// Nothing but the inputs in the folder: no output, no temporary file.
    #[track_caller]
    fn assert_nothing_written(&self, inputs: &[&Path]) {
        let mut keep = vec![self.vis.as_path(), self.tir.as_path()];
        keep.extend_from_slice(inputs);
        let extra = extra_files(self.dir.path(), &keep);
        assert!(extra.is_empty(), "files left behind: {extra:?}");
    }
}

#[test]
fn unreadable_pngs_fail_cleanly_in_every_slot() {
    let s = setup();
    let grey = frame(16, 12);
    let mut good = Vec::new();
    image::write_buffer_with_format(
        &mut std::io::Cursor::new(&mut good),
        &grey.data,
        16,
        12,
        image::ExtendedColorType::L8,
        image::ImageFormat::Png,
    )
    .unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty.png", Vec::new(), "not a valid PNG"),
        ("junk.png", b"this is not an image at all".to_vec(), "not a valid PNG"),
        ("truncated.png", good[..good.len() / 2].to_vec(), "not a valid PNG"),
        ("header-only.png", good[..33].to_vec(), "not a valid PNG"),
        (
            "bad-crc.png",
            {
                let mut b = good.clone();
                b[30] ^= 0xFF; // IHDR's CRC no longer matches
                b
            },
            "not a valid PNG",
        ),
        // Declares 100000 × 100000 (10 GB): refused from its header by the memory limit, not
        // allocated (issue 24; the test below covers every verb).
        ("huge.png", png(100_000, 100_000, 0, 8, &[vec![0u8; 16]], None), "memory limit"),
    ];
    for (name, bytes, needle) in &cases {
        let bad = s.write(name, bytes);
        for (slot, args) in [
            ("vis", vec!["fuse", p(&bad), p(&s.tir), p(&s.out)]),
            ("tir", vec!["fuse", p(&s.vis), p(&bad), p(&s.out)]),
            ("rescale", vec!["rescale", "--width", "4", "--height", "4", p(&bad), p(&s.out)]),
        ] {
            let o = fusion(&args);
            assert_clean_failure(&o, needle);
            if slot != "rescale" {
                let which = if slot == "vis" { "visible image" } else { "thermal image" };
                assert_clean_failure(&o, which);
            }
            s.assert_nothing_written(&[&bad]);
        }
        std::fs::remove_file(&bad).unwrap();
    }
    let missing = s.dir.path().join("missing.png");
    assert_clean_failure(&fusion(&["fuse", p(&missing), p(&s.tir), p(&s.out)]), "cannot open");
    assert_clean_failure(&fusion(&["fuse", p(&s.vis), p(&missing), p(&s.out)]), "thermal image");
    assert_clean_failure(&fusion(&["fuse", p(&s.vis), p(s.dir.path()), p(&s.out)]), "thermal image");
    s.assert_nothing_written(&[]);
}

/// `fusion fuse` converts colour, palette, grey+alpha and 1-bit images to 8-bit grey (BT.601
/// weights, alpha dropped) and refuses 16-bit grey with a clear message; `fusion rescale`
/// refuses colour (it keeps 8- or 16-bit grey as is).
#[test]
fn colour_palette_and_bit_depths_are_converted_or_refused_clearly() {
    let s = setup();
    let (w, h) = (8u32, 6u32);
    // Palette: red, green, blue, white.
    let plte = [255u8, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255];
    let index_rows: Vec<Vec<u8>> = (0..h).map(|y| (0..w).map(|x| ((x + y) % 4) as u8).collect()).collect();
    let pal4_rows: Vec<Vec<u8>> =
        index_rows.iter().map(|r| r.chunks(2).map(|c| (c[0] << 4) | c[1]).collect()).collect();
    let rgb_rows: Vec<Vec<u8>> = index_rows
        .iter()
        .map(|r| r.iter().flat_map(|&i| plte[3 * i as usize..3 * i as usize + 3].to_vec()).collect())
        .collect();
    let rgba_rows: Vec<Vec<u8>> = index_rows
        .iter()
        .map(|r| {
            r.iter()
                .flat_map(|&i| plte[3 * i as usize..3 * i as usize + 3].iter().copied().chain([128]))
                .collect()
        })
        .collect();
    let rgba16_rows: Vec<Vec<u8>> =
        rgba_rows.iter().map(|r| r.iter().flat_map(|&v| [v, v]).collect()).collect();
    let grey_alpha_rows: Vec<Vec<u8>> =
        (0..h).map(|y| (0..w).flat_map(|x| [(x * 30 + y) as u8, 7]).collect()).collect();
    let bit1_rows: Vec<Vec<u8>> =
        (0..h).map(|y| vec![if y % 2 == 0 { 0b1010_1010 } else { 0b0101_0101 }]).collect();
    // Expected grey values of the colour images: rgb2gray of red, green, blue, white.
    let pal_grey = |i: u8| [76u8, 150, 29, 255][i as usize];
    let expect_pal: Vec<u8> = index_rows.iter().flatten().map(|&i| pal_grey(i)).collect();
    let cases: Vec<(&str, Vec<u8>, Vec<u8>)> = vec![
        ("palette8.png", png(w, h, 3, 8, &index_rows, Some(&plte)), expect_pal.clone()),
        ("palette4.png", png(w, h, 3, 4, &pal4_rows, Some(&plte)), expect_pal.clone()),
        ("rgb.png", png(w, h, 2, 8, &rgb_rows, None), expect_pal.clone()),
        ("rgba.png", png(w, h, 6, 8, &rgba_rows, None), expect_pal),
        (
            "grey-alpha.png",
            png(w, h, 4, 8, &grey_alpha_rows, None),
            (0..h).flat_map(|y| (0..w).map(move |x| (x * 30 + y) as u8)).collect(),
        ),
        (
            "grey1.png",
            png(w, h, 0, 1, &bit1_rows, None),
            (0..h).flat_map(|y| (0..w).map(move |x| if (x + y) % 2 == 0 { 255 } else { 0 })).collect(),
        ),
    ];
    // 16-bit colour is refused like 16-bit grey is for an 8-bit input (not cut to 8 bits silently).
    let rgba16 = s.write("rgba16.png", &png(w, h, 6, 16, &rgba16_rows, None));
    assert_clean_failure(
        &fusion(&["fuse", "--method", "adf", "--rescale", "none", p(&rgba16), p(&rgba16), p(&s.out)]),
        "16-bit colour",
    );
    for (name, bytes, expect) in &cases {
        let input = s.write(name, bytes);
        // As both bands of a same-size pair: the fused image of two identical frames is the frame.
        // (`--color gray`: a colour visible frame is otherwise kept in colour, cli_real_data.rs.)
        let o = fusion(&[
            "fuse",
            "--method",
            "adf",
            "--rescale",
            "none",
            "--color",
            "gray",
            p(&input),
            p(&input),
            p(&s.out),
        ]);
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let converted = load_gray_u8(&s.out, ColorPolicy::Refuse).unwrap();
        assert_eq!((converted.width, converted.height), (w as usize, h as usize), "{name}");
        let loaded = load_gray_u8(&input, ColorPolicy::Bt601).unwrap();
        assert_eq!(&loaded.data, expect, "{name}: conversion to grey");
        std::fs::remove_file(&s.out).unwrap();
        let o = fusion(&["rescale", "--width", "4", "--height", "3", p(&input), p(&s.out)]);
        if name.starts_with("grey") {
            assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
            std::fs::remove_file(&s.out).unwrap();
        } else {
            assert_clean_failure(&o, "colour image");
        }
        std::fs::remove_file(&input).unwrap();
    }
    // 16-bit grey: refused as the visible frame (the AGC is for the thermal band); as the
    // thermal frame it goes through the AGC (cli_real_data.rs).
    let g16 = s.write("grey16.png", &png(w, h, 0, 16, &vec![vec![0x12u8; 2 * w as usize]; h as usize], None));
    assert_clean_failure(&fusion(&["fuse", p(&g16), p(&s.tir), p(&s.out)]), "is 16-bit");
    s.assert_nothing_written(&[&g16, &rgba16]);
}

/// Frames and output sizes over the core's capacity are refused before anything large is
/// allocated (no out-of-memory abort).
#[test]
fn sizes_over_the_capacity_are_refused() {
    let s = setup();
    let side = fusion_nostd::MAX_DIMENSION + 1;
    let wide = s.write("wide.png", &png(side as u32, 1, 0, 8, &[vec![9u8; side]], None));
    assert_clean_failure(
        &fusion(&["fuse", "--rescale", "none", p(&wide), p(&wide), p(&s.out)]),
        &format!("dimension {side} exceeds the maximum"),
    );
    assert_clean_failure(&fusion(&["fuse", p(&s.vis), p(&wide), p(&s.out)]), "exceeds the maximum");
    for (w, h) in [("1000000", "1000000"), ("16385", "1"), ("17179869184", "2147483648")] {
        assert_clean_failure(
            &fusion(&["rescale", "--width", w, "--height", h, p(&s.vis), p(&s.out)]),
            "exceeds",
        );
    }
    assert_clean_failure(
        &fusion(&["rescale", "--width", "0", "--height", "3", p(&s.vis), p(&s.out)]),
        "zero",
    );
    // Same-size policy with different sizes.
    assert_clean_failure(
        &fusion(&["fuse", "--rescale", "none", p(&s.vis), p(&s.tir), p(&s.out)]),
        "does not match",
    );
    s.assert_nothing_written(&[&wide]);
}

/// Unwritable outputs: a folder that does not exist, a path that is a folder, a path below a
/// regular file. Nothing is left behind, not even the temporary file; with `--raw`, a failing
/// raw path leaves no PNG either.
#[test]
fn unwritable_outputs_leave_nothing_behind() {
    let s = setup();
    let folder = s.dir.path().join("sub");
    std::fs::create_dir(&folder).unwrap();
    let below_file = s.vis.join("out.png");
    for target in [s.dir.path().join("no/such/dir/out.png"), folder.clone(), below_file.clone()] {
        let o = fusion(&["fuse", p(&s.vis), p(&s.tir), p(&target)]);
        assert_clean_failure(&o, "cannot write");
        let o = fusion(&["rescale", "--width", "4", "--height", "4", p(&s.vis), p(&target)]);
        assert_clean_failure(&o, "cannot write");
    }
    assert!(std::fs::read_dir(&folder).unwrap().next().is_none(), "nothing written into the folder");
    let o =
        fusion(&["fuse", "--raw", p(&s.dir.path().join("no/dir/raw.npy")), p(&s.vis), p(&s.tir), p(&s.out)]);
    assert_clean_failure(&o, "cannot");
    let keep = [s.vis.as_path(), s.tir.as_path(), folder.as_path()];
    let extra = extra_files(s.dir.path(), &keep);
    assert!(extra.is_empty(), "files left behind: {extra:?}");
}

/// Issue 44, classes 3 and 4: `--quiet` silences notes, not errors (the one-line error is
/// printed with and without it); a single-pair fuse refuses to write over one of its inputs,
/// by its own name, a symbolic link or a hard link, and leaves it as it was.
#[test]
fn quiet_still_prints_errors_and_inputs_are_never_outputs() {
    let s = setup();
    let missing = s.dir.path().join("nonexist.png");
    for quiet in [false, true] {
        let mut args = vec!["fuse", p(&missing), p(&s.tir), p(&s.out)];
        if quiet {
            args.insert(0, "--quiet");
        }
        assert_clean_failure(&fusion(&args), "nonexist.png");
    }
    // Class 11: missing inputs are named, before the output's name is judged.
    let o = fusion(&[
        "fuse",
        p(&s.dir.path().join("nodir1")),
        p(&s.dir.path().join("nodir2")),
        p(&s.dir.path().join("o")),
    ]);
    assert_clean_failure(&o, "nodir1: no such file");
    let vis_before = std::fs::read(&s.vis).unwrap();
    let tir_before = std::fs::read(&s.tir).unwrap();
    let link = s.dir.path().join("link.png");
    std::os::unix::fs::symlink(&s.vis, &link).unwrap();
    let hard = s.dir.path().join("hard.png");
    std::fs::hard_link(&s.tir, &hard).unwrap();
    for target in [&s.vis, &s.tir, &link, &hard] {
        let o = fusion(&["fuse", p(&s.vis), p(&s.tir), p(target)]);
        assert_clean_failure(&o, "is the input");
    }
    assert_eq!(std::fs::read(&s.vis).unwrap(), vis_before, "visible input changed");
    assert_eq!(std::fs::read(&s.tir).unwrap(), tir_before, "thermal input changed");
    s.assert_nothing_written(&[&link, &hard]);
}

/// Memory is judged before it is taken (issue 24, item 2): from the headers, in one line naming
/// the input, against `--max-memory` (default 8 GiB) — never an allocation-failure abort.
#[test]
fn memory_is_estimated_from_the_headers_before_anything_large_is_allocated() {
    let s = setup();
    // A 1-bit PNG of a few hundred bytes declaring 70 000 × 70 000 pixels (4.9·10⁹): refused
    // from its header by every verb that reads it, before the image data is touched (its data
    // is one row: decoding would fail later with another message).
    let huge = s.write("huge.png", &png(70_000, 70_000, 0, 1, &[vec![0u8; 8750]], None));
    for args in [
        vec!["eval", p(&huge), p(&huge), p(&huge)],
        vec!["fuse", p(&huge), p(&s.tir), p(&s.out)],
        vec!["fuse", "--method", "gff", p(&s.vis), p(&huge), p(&s.out)],
        vec!["rescale", "--width", "8", "--height", "8", p(&huge), p(&s.out)],
    ] {
        let o = fusion(&args);
        assert_clean_failure(&o, "memory limit");
        assert!(String::from_utf8_lossy(&o.stderr).contains("huge.png"), "{args:?}: the input is named");
    }
    // --max-memory moves the limit: a 256² pair fits the core but not 1 MiB for the f64 reference.
    let (v, t) = (s.dir.path().join("v256.png"), s.dir.path().join("t256.png"));
    save_gray_u8(&v, &frame(256, 256)).unwrap();
    save_gray_u8(&t, &frame(128, 128)).unwrap();
    let o = fusion(&["--max-memory", "1M", "fuse", "--engine", "reference", p(&v), p(&t), p(&s.out)]);
    assert_clean_failure(&o, "memory limit");
    let o = fusion(&["--max-memory", "64M", "fuse", "--engine", "reference", p(&v), p(&t), p(&s.out)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_file(&s.out).unwrap();
    let o = fusion(&["--max-memory", "1M", "eval", "--suite", "vifb", p(&v), p(&v), p(&v)]);
    assert_clean_failure(&o, "memory limit");
    // Output sizes and renders are judged from the arguments.
    let o = fusion(&[
        "--max-memory",
        "100M",
        "rescale",
        "--width",
        "16384",
        "--height",
        "16384",
        p(&v),
        p(&s.out),
    ]);
    assert_clean_failure(&o, "memory limit");
    let rendered = s.dir.path().join("render");
    let o = fusion(&[
        "--max-memory",
        "100M",
        "render",
        "--out",
        p(&rendered),
        "--vis-size",
        "4096",
        "--frames",
        "1",
    ]);
    assert_clean_failure(&o, "memory limit");
    assert!(!rendered.exists(), "nothing rendered");
    // A malformed size is a usage error (clap's exit status 2, with the usage line).
    let o = fusion(&["--max-memory", "lots", "eval", p(&v), p(&v), p(&v)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a size"));
    s.assert_nothing_written(&[&huge, &v, &t]);
}
