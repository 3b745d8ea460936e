//! Issue 9, determinism: the same inputs give the same output bytes on every run, whatever the
//! scratch held before (zeros, garbage, or the leftovers of a previous call on a different
//! frame size), through the pipeline and through strided views.
//!
//! Across builds and targets: the core is integer arithmetic throughout the fusion path (the
//! only floating point is the `f32` rescaler, which the pipeline does not use), and the
//! firmware budget run (`fusion budget`, `host-harness/src/budget/`) compares the Cortex-M7 and
//! RV32 outputs (and the Cortex-A53's) with the host's byte for byte; `fw_selftest_matches_the_host` below compares the
//! checksums the firmware self-test prints (release, fat LTO, Cortex-M7 and RV32 under QEMU)
//! with this test build's (x86-64, debug assertions on) when the images and QEMU are there.

use fusion_io::Gray;
use fusion_nostd::pipeline::{FuseConfig, Method, RescalePolicy, fuse};
use fusion_nostd::{AdaptiveParams, AdfParams, FrameMut, FrameRef, IfevipParams, ScratchMut, TsifsdParams};
use fusion_tests::{TestRng, scene};

fn methods() -> Vec<Method> {
    Method::all().to_vec()
}

/// Heap scratch whose every plane is pre-filled by `fill(plane, index)`.
struct Dirty {
    planes: [Vec<i32>; 3],
    band: Vec<u8>,
}

impl Dirty {
    fn new(pixels: usize, fill: impl Fn(usize, usize) -> i32) -> Self {
        let planes = std::array::from_fn(|k| (0..pixels).map(|i| fill(k, i)).collect());
        let band = (0..pixels).map(|i| fill(3, i) as u8).collect();
        Self { planes, band }
    }

    fn view(&mut self) -> ScratchMut<'_> {
        let [a, b, c] = &mut self.planes;
        ScratchMut::with_band([a, b, c], &mut self.band)
    }
}

fn fuse_with(vis: &Gray<u8>, tir: &Gray<u8>, p: &FuseConfig, scratch: &mut ScratchMut<'_>) -> Vec<u8> {
    let grid =
        if p.rescale == RescalePolicy::VisDown { (tir.width, tir.height) } else { (vis.width, vis.height) };
    let mut out = Gray::<u8>::new(grid.0, grid.1);
    fuse(vis.view().unwrap(), tir.view().unwrap(), out.view_mut().unwrap(), scratch, p)
        .unwrap_or_else(|e| panic!("{p:?}: {e}"));
    out.data
}

const FILLS: [fn(usize, usize) -> i32; 4] = [
    |_, _| 0,
    |_, _| -1,
    |k, i| (i as i32).wrapping_mul(0x9E37_79B9u32 as i32) ^ (k as i32) << 29,
    |k, i| if (i + k) % 2 == 0 { i32::MAX } else { i32::MIN },
];

/// Every method and variant, VIS 2× TIR and same-size pairs at odd and narrow sizes (narrower
/// than TSIFSD's 35-pixel window, smaller than IFEVIP's 512² grid): the output does not depend
/// on what the scratch held.
#[test]
fn output_does_not_depend_on_scratch_contents() {
    let sizes =
        [(64, 48, 32, 24), (37, 23, 19, 12), (8, 40, 8, 40), (3, 70, 3, 70), (90, 5, 45, 3), (1, 1, 1, 1)];
    for (vw, vh, tw, th) in sizes {
        let (vis, tir) = (scene(vw, vh, 1), scene(tw, th, 2));
        for method in methods() {
            let policies: &[RescalePolicy] = if (vw, vh) == (tw, th) {
                &[RescalePolicy::None]
            } else {
                &[RescalePolicy::TirUp, RescalePolicy::VisDown]
            };
            for &rescale in policies {
                let p = FuseConfig { rescale, method, ..Default::default() };
                let pixels = p.scratch_pixels((vw, vh), (tw, th)).unwrap();
                let want = fuse_with(&vis, &tir, &p, &mut Dirty::new(pixels, FILLS[0]).view());
                for (k, fill) in FILLS.iter().enumerate().skip(1) {
                    let got = fuse_with(&vis, &tir, &p, &mut Dirty::new(pixels + 17, fill).view());
                    let n = got.iter().zip(&want).filter(|(a, b)| a != b).count();
                    assert_eq!(n, 0, "{vw}x{vh}/{tw}x{th} {p:?}: {n} pixels differ with scratch fill {k}");
                }
            }
        }
    }
}

/// One scratch reused across calls of different sizes and methods (as a firmware does): every
/// result equals the result with fresh scratch.
#[test]
fn scratch_reuse_across_sizes_and_methods() {
    let mut rng = TestRng::new(5);
    let pairs: Vec<(Gray<u8>, Gray<u8>)> =
        [(96, 64, 48, 32), (31, 17, 16, 9), (50, 50, 25, 25), (7, 3, 4, 2)]
            .into_iter()
            .map(|(vw, vh, tw, th)| (rng.image_u8(vw, vh), scene(tw, th, 4)))
            .collect();
    let capacity = 600 * 600;
    let mut shared = Dirty::new(capacity, FILLS[2]);
    for round in 0..2 {
        for (vis, tir) in &pairs {
            for method in methods() {
                let p = FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() };
                let reused = fuse_with(vis, tir, &p, &mut shared.view());
                let pixels = p.scratch_pixels((vis.width, vis.height), (tir.width, tir.height)).unwrap();
                let fresh = fuse_with(vis, tir, &p, &mut Dirty::new(pixels, FILLS[0]).view());
                assert!(
                    reused == fresh,
                    "round {round} {}x{} {p:?}: reused scratch changed the result",
                    vis.width,
                    vis.height
                );
            }
        }
    }
}

/// Strided views (garbage in the gaps) give the bytes of the packed views.
#[test]
fn strided_views_give_the_packed_result() {
    let (vw, vh, tw, th) = (45, 29, 23, 15);
    let (vis, tir) = (scene(vw, vh, 7), scene(tw, th, 8));
    let spread = |g: &Gray<u8>, stride: usize| {
        let mut buf = vec![0xC3u8; stride * g.height];
        for (y, row) in g.data.chunks(g.width).enumerate() {
            buf[y * stride..y * stride + g.width].copy_from_slice(row);
        }
        buf
    };
    for method in methods() {
        for rescale in [RescalePolicy::TirUp, RescalePolicy::VisDown] {
            let p = FuseConfig { rescale, method, ..Default::default() };
            let pixels = p.scratch_pixels((vw, vh), (tw, th)).unwrap();
            let want = fuse_with(&vis, &tir, &p, &mut Dirty::new(pixels, FILLS[0]).view());
            let (vs, ts) = (vw + 5, tw + 2);
            let (vbuf, tbuf) = (spread(&vis, vs), spread(&tir, ts));
            let (gw, gh) = if rescale == RescalePolicy::TirUp { (vw, vh) } else { (tw, th) };
            let os = gw + 3;
            let mut obuf = vec![0u8; os * gh];
            fuse(
                FrameRef::with_stride(&vbuf, vw, vh, vs).unwrap(),
                FrameRef::with_stride(&tbuf, tw, th, ts).unwrap(),
                FrameMut::with_stride(&mut obuf, gw, gh, os).unwrap(),
                &mut Dirty::new(pixels, FILLS[3]).view(),
                &p,
            )
            .unwrap();
            let got: Vec<u8> = (0..gh).flat_map(|y| obuf[y * os..y * os + gw].to_vec()).collect();
            assert!(got == want, "{p:?}: strided result differs");
        }
    }
}

/// FNV-1a, as the firmware computes it.
fn fnv1a(data: &[u8]) -> u32 {
    data.iter().fold(0x811c_9dc5u32, |h, &b| (h ^ u32::from(b)).wrapping_mul(0x0100_0193))
}

/// The newest modification time of the files under `dir`.
fn newest(dir: &std::path::Path) -> Option<std::time::SystemTime> {
    let mut t = None;
    for e in std::fs::read_dir(dir).ok()?.flatten() {
        let p = e.path();
        let m = if p.is_dir() { newest(&p) } else { e.metadata().ok()?.modified().ok() };
        t = t.max(m);
    }
    t
}

/// The firmware's built-in self-test pair (`fw/src/runner.rs`, `self_test`): VIS 256² with a
/// ramp-textured box, TIR 128² hashed noise, TIR upscaled, the three methods with default
/// (flight) parameters. The host result must equal each target's, byte for byte (checked by
/// FNV-1a and the guard bits the image prints).
#[test]
fn fw_selftest_matches_the_host() {
    let vis = Gray {
        width: 256,
        height: 256,
        data: (0..256 * 256)
            .map(|i| {
                let (x, y) = (i % 256, i / 256);
                if (64..192).contains(&x) && (96..160).contains(&y) { (x + y) as u8 } else { 3 }
            })
            .collect(),
    };
    let tir = Gray {
        width: 128,
        height: 128,
        data: (0..128 * 128usize).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8 / 4 + 60).collect(),
    };
    let mut host = Vec::new();
    for (name, method) in [
        ("adf", Method::Adf(AdfParams::default())),
        ("tsifsd", Method::Tsifsd(TsifsdParams::default())),
        ("ifevip", Method::Ifevip(IfevipParams::default())),
        ("adaptive", Method::Adaptive(AdaptiveParams::default())),
    ] {
        let p = FuseConfig { rescale: RescalePolicy::TirUp, method, ..Default::default() };
        let fused = fusion_engine::methods::fuse_core(&vis, &tir, &p, false).unwrap();
        host.push(format!(
            "@fw selftest {name} guards 0x{:02x} fnv1a {:08x}",
            fused.guards.0,
            fnv1a(&fused.image.data)
        ));
    }
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let Some(core_time) = newest(&root.join("fusion-nostd/src")) else { return };
    let targets = [
        ("thumbv7em-none-eabihf", vec!["qemu-system-arm", "-machine", "mps2-an500", "-cpu", "cortex-m7"]),
        (
            "riscv32imac-unknown-none-elf",
            vec!["qemu-system-riscv32", "-machine", "virt", "-bios", "none", "-m", "64M"],
        ),
        (
            "aarch64-unknown-none",
            vec!["qemu-system-aarch64", "-machine", "virt", "-cpu", "cortex-a53", "-m", "128M"],
        ),
    ];
    for (target, qemu) in targets {
        let elf = root.join("fw/target").join(target).join("release/fusion-fw");
        let fresh = std::fs::metadata(&elf).and_then(|m| m.modified()).is_ok_and(|t| t >= core_time);
        if !fresh {
            println!(
                "{target}: no firmware image newer than the core sources; skipped (cd fw && cargo build --release)"
            );
            continue;
        }
        // An empty folder (no job.bin): the image runs its self-test.
        let dir = std::env::temp_dir().join(format!("fusion-fw-selftest-{}-{target}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let run = std::process::Command::new("timeout")
            .arg("60")
            .args(&qemu)
            .args(["-nographic", "-semihosting-config", "enable=on,target=native", "-kernel"])
            .arg(&elf)
            .current_dir(&dir)
            .output();
        let _ = std::fs::remove_dir_all(&dir);
        let Some(run) = run.ok().filter(|o| o.status.code() != Some(127)) else {
            println!("{target}: {} not available; skipped", qemu[0]);
            continue;
        };
        let console = String::from_utf8_lossy(&run.stdout);
        let lines: Vec<String> =
            console.lines().filter(|l| l.starts_with("@fw selftest")).map(|l| l.trim().to_string()).collect();
        assert!(run.status.success(), "{target}: firmware self-test failed:\n{console}");
        assert_eq!(lines, host, "{target}: firmware and host results differ");
        println!("{target}: {} self-test results identical to the host's", lines.len());
    }
}
