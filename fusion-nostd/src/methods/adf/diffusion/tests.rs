extern crate std;
use super::super::tests::noise;
use super::super::{AdfParams, Variant};
use super::flux::*;
use super::pack::*;
use super::row::*;
use super::row_pipeline::*;
use super::*;
use crate::{Error, FrameRef};
use std::vec::Vec;

fn params(kappa: u16, dt_milli: u16) -> AdfParams {
    AdfParams { kappa, dt_milli, ..AdfParams::default() }
}

/// The flux function against `Δt/2·∇·exp(−(∇/κ)²)` (state units) over every difference:
/// the error in grey levels per pair flux, for the published κ, Δt and the extremes.
#[test]
fn flux_function_error_is_within_its_bound() {
    for (kappa, dt) in [(30u16, 150u16), (1, 150), (10, 250), (64, 100), (100, 150), (255, 250)] {
        let fx = FluxFn::new(&params(kappa, dt));
        let kq = f64::from(kappa) * 128.0;
        let mut max_err = 0.0f64;
        for d in -32767..=32767 {
            let t = f64::from(d) / kq;
            let want = f64::from(dt) / 2000.0 * f64::from(d) * libm::exp(-t * t);
            max_err = max_err.max((f64::from(fx.eval(d)) - want).abs());
        }
        // A state unit is 1/128 grey level.
        let levels = max_err / 128.0;
        std::println!(
            "κ {kappa} Δt {dt}: max |F − Δt/2·∇·exp(−(∇/κ)²)| = {max_err:.3} units ({levels:.5} levels)"
        );
        // The nodes' rounding (½ unit), the interpolation's rounding (½ unit) and its
        // error h²/8·max|f''| over a segment of h = 2ᵏ units, with
        // f'' = Δt/2·exp(−x²)·(4x³ − 6x)/κ_q (x = ∇/κ_q) and |exp(−x²)·(4x³ − 6x)| < 2.
        let h = f64::from(1u32 << fx.shift);
        let bound = 1.0 + h * h / 8.0 * 2.0 * f64::from(dt) / 2000.0 / kq;
        assert!(max_err <= bound, "κ {kappa} Δt {dt}: {max_err} > {bound}");
    }
}

/// The one-product form is the linear interpolation of the nodes, rounded half up, for
/// every difference, κ and a spread of Δt (so the base and slope never wrap in `i16`).
#[test]
fn flux_is_the_interpolation_of_its_nodes() {
    for kappa in 1..=255u16 {
        for dt in [1u16, 77, 150, 250] {
            let p = params(kappa, dt);
            let (fx, (k, node)) = (FluxFn::new(&p), FluxFn::nodes(&p));
            let limit = ((SEGMENTS as i64) << k) - 1;
            for d in 0..=i16::MAX as i64 {
                let m = d.min(limit);
                let (j, q) = ((m >> k) as usize, m & ((1 << k) - 1));
                let rise = i64::from(node[j + 1] - node[j]);
                let want = i64::from(node[j]) + ((q * rise + (1 << (k - 1))) >> k);
                assert_eq!(i64::from(fx.eval(d as i32)), want, "κ {kappa} Δt {dt} ∇ {d}");
            }
        }
    }
}

/// Odd, 0 from `4κ` on, never beyond `Δt/2·κ·0.429` (+1) ≤ [`MAX_FLUX`]: the twelve-term
/// step stays inside `i16` for every parameter set.
#[test]
fn flux_is_odd_bounded_and_zero_far_away() {
    // The largest flux of every κ at the largest Δt: at most MAX_FLUX.
    for kappa in 1..=255u16 {
        let fx = FluxFn::new(&params(kappa, 250));
        let largest = (0..=i16::MAX as i32).map(|d| fx.eval(d).abs()).max().unwrap_or(0);
        let bound = libm::round(0.125 * f64::from(kappa) * 128.0 * 0.4306 + 0.5) as i32;
        assert!(largest <= bound && bound <= MAX_FLUX, "κ {kappa}: {largest} > {bound}");
    }
    for (kappa, dt) in [(30u16, 150u16), (1, 1), (7, 250), (255, 250)] {
        let fx = FluxFn::new(&params(kappa, dt));
        let kq = i32::from(kappa) * 128;
        let bound = (f64::from(dt) / 2000.0 * f64::from(kq) * 0.4289).ceil() as i32 + 1;
        assert!(bound <= MAX_FLUX, "κ {kappa} Δt {dt}: {bound}");
        for d in 0..=32767 {
            assert_eq!(fx.eval(-d), -fx.eval(d), "κ {kappa} {d}");
            assert!(fx.eval(d).abs() <= bound, "κ {kappa} {d}: {} > {bound}", fx.eval(d));
            if d >= 4 * kq {
                assert_eq!(fx.eval(d), 0, "κ {kappa} {d}");
            }
        }
    }
}

/// The table, (on x86-64 with AVX-512) the thirty-two-lane form, (with AVX2) the form that
/// reads two sixteen-lane registers at once and (on AArch64, under `qemu-aarch64` in CI) the
/// NEON form that reads two eight-lane registers at once give the function's value for every
/// difference and every κ class (the AVX2 form: every 16-bit difference, −32768 read as −32767
/// like the table; the NEON form: every difference `x − c` the table covers, for two centres).
#[test]
fn table_and_avx512_equal_the_function_exhaustively() {
    let mut table = std::vec![0i32; TABLE_WORDS];
    // The byte tables' two layouts (one-byte and two-byte nodes) both occur below (the AVX2
    // form's on x86-64, the NEON form's on AArch64).
    #[cfg(any(target_arch = "x86_64", all(target_arch = "aarch64", target_feature = "neon")))]
    let mut layouts = std::collections::BTreeSet::new();
    for kappa in [1u16, 2, 7, 16, 30, 63, 64, 65, 100, 128, 129, 200, 255] {
        for dt in [1u16, 150, 250] {
            let fx = FluxFn::new(&params(kappa, dt));
            let Some(t) = table_view(&mut table) else { panic!("table") };
            fx.tabulate(t);
            let t = Table(t);
            for d in -32768..=32767 {
                assert_eq!(t.flux(d), fx.eval(d), "κ {kappa} Δt {dt} ∇ {d}");
            }
            #[cfg(target_arch = "x86_64")]
            if crate::cpu::has_avx512bw() {
                let all: Vec<i16> = (-32767..=32767i32).map(|d| d as i16).chain([0]).collect();
                for block in all.chunks_exact(32) {
                    let mut lanes = [0i16; 32];
                    lanes.copy_from_slice(block);
                    // SAFETY: the CPU has AVX-512 F and BW (checked above).
                    let got = unsafe { avx512::flux32(&fx, lanes) };
                    assert_eq!(got, lanes.map(|d| fx.eval(i32::from(d)) as i16), "κ {kappa} Δt {dt}");
                }
            }
            #[cfg(target_arch = "x86_64")]
            if crate::cpu::has_avx2() {
                layouts.insert(avx2::Tables::new(&fx).map(|t| t.two_byte_nodes()));
                // Each block of 16 differences alone (four copies: it takes the form's
                // first-quarter path exactly when all its segments are below 16), four
                // consecutive blocks, and each block beside three from elsewhere in the range
                // (slot k runs through every block with the odd step (2k + 1)·7919).
                let all: Vec<i16> = (i16::MIN..=i16::MAX).collect();
                let blocks: Vec<[i16; 16]> = all.chunks_exact(16).filter_map(|c| c.try_into().ok()).collect();
                let n = blocks.len();
                let want = |x: [i16; 16]| x.map(|d| t.flux(i32::from(d)) as i16);
                for i in 0..n {
                    let alone = [blocks[i]; 4];
                    let consecutive = [0, 1, 2, 3].map(|k| blocks[(4 * i + k) % n]);
                    let mixed = [0, 1, 2, 3].map(|k| blocks[(i * (2 * k + 1) * 7919 + k * 1234) % n]);
                    for x in [alone, mixed, consecutive].into_iter().take(if 4 * i < n { 3 } else { 2 }) {
                        // SAFETY: the CPU has AVX2 (checked above).
                        let got = unsafe { avx2::flux_four(&fx, x) };
                        // Every parameter's rises fit the AVX2 form's bytes.
                        assert_eq!(got, Some(x.map(want)), "κ {kappa} Δt {dt}");
                    }
                }
            }
            // The NEON form (under `qemu-aarch64` in CI): every difference `x − c` for two
            // centres, each block of eight alone (both registers) and beside a block from
            // elsewhere in the range; both table layouts occur.
            #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
            {
                layouts.insert(fx.byte_tables().map(|b| b.node_hi.is_some()));
                for c in [0i16, 16384] {
                    let span = i32::from(c) - 32768..=i32::from(c) + 32767;
                    let xs: Vec<i16> =
                        (i16::MIN..=i16::MAX).filter(|&x| span.contains(&i32::from(x))).collect();
                    let blocks: Vec<[i16; 8]> =
                        xs.chunks_exact(8).filter_map(|b| b.try_into().ok()).collect();
                    let n = blocks.len();
                    let pairs: Vec<[[i16; 8]; 2]> = (0..n)
                        .flat_map(|i| [[blocks[i]; 2], [blocks[i], blocks[(i * 7919 + 1234) % n]]])
                        .collect();
                    let want = |x: [i16; 8]| x.map(|x| t.flux(i32::from(x) - i32::from(c)) as i16);
                    let mut got = std::vec![[[0i16; 8]; 2]; pairs.len()];
                    // Every parameter's rises fit the NEON form's bytes.
                    assert_eq!(neon::flux_pairs(&fx, &pairs, [c; 8], &mut got), Some(()));
                    let want: Vec<[[i16; 8]; 2]> = pairs.iter().map(|p| p.map(want)).collect();
                    assert!(got == want, "κ {kappa} Δt {dt} c {c}");
                }
            }
        }
    }
    #[cfg(target_arch = "x86_64")]
    if crate::cpu::has_avx2() {
        assert_eq!(layouts.into_iter().collect::<Vec<_>>(), [Some(false), Some(true)]);
    }
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    assert_eq!(layouts.into_iter().collect::<Vec<_>>(), [Some(false), Some(true)]);
}

/// Every way to run the diffusion gives the same bits: the row pipeline in one group (with
/// the table, and with each SIMD loop the CPU has) and in several groups without the table,
/// and plain Jacobi sweeps with all eight fluxes per pixel; sizes from one row to one
/// column, both borders, parameters that saturate the sums.
#[test]
fn every_schedule_gives_the_same_bits() -> Result<(), Error> {
    let sizes =
        [(1usize, 6usize), (6, 1), (7, 2), (5, 6), (1, 60), (2, 40), (3, 50), (17, 9), (31, 40), (64, 23)];
    let all_params = [
        AdfParams::default(),
        AdfParams { iterations: 7, dt_milli: 250, kappa: 5, ..AdfParams::default() },
        AdfParams { iterations: 23, dt_milli: 100, kappa: 200, ..AdfParams::default() },
        AdfParams { iterations: 3, dt_milli: 250, kappa: 255, ..AdfParams::default() },
        AdfParams { iterations: 2, dt_milli: 1, kappa: 1, ..AdfParams::default() },
    ];
    for (k, &(w, h)) in sizes.iter().enumerate() {
        for levels in [2u32, 256] {
            let (sv, st) = (noise(w * h, 7 + k as u32, levels), noise(w * h, 70 + k as u32, levels));
            let (fv, ft) = (FrameRef::new(&sv, w, h)?, FrameRef::new(&st, w, h)?);
            for p in all_params {
                for variant in [Variant::Classic, Variant::Flight] {
                    let p = AdfParams { variant, ..p };
                    let mut results = Vec::new();
                    let big = TABLE_WORDS + group_words(w, usize::from(p.iterations));
                    let several = group_words(w, 2);
                    let (vis, tir) = (Band::Frame(fv), Band::Frame(ft));
                    // The forms of `select_form` (one this CPU lacks runs the portable loop).
                    let runs =
                        [(big, 0), (big, 1), (big, 2), (big, 3), (several, 0), (several, 2), (several, 3)];
                    for (work_len, form) in runs {
                        let mut d = Diffusion::new(&p);
                        select_form(&mut d, form);
                        let (mut a, mut work) = (std::vec![0i32; w * h], std::vec![0i32; work_len]);
                        diffuse_with(d, vis, tir, (w, h), p.iterations, &mut a, &mut work)?;
                        results.push(a);
                    }
                    // Plain sweeps with all eight fluxes per pixel.
                    let mut nothing = [];
                    let (pipe, _) = RowPipeline::new(Diffusion::new(&p), (w, h), &mut nothing, 0);
                    let (mut a, mut b) = (std::vec![0i32; w * h], std::vec![0i32; w * h]);
                    pipe.sweeps(vis, tir, &mut a, &mut b, p.iterations);
                    results.push(a);
                    for r in &results[1..] {
                        assert_eq!(r, &results[0], "{w}x{h} {p:?}");
                    }
                }
            }
        }
    }
    Ok(())
}

/// A [`Band::Level`] is the constant frame of that level.
#[test]
fn a_level_band_is_a_constant_frame() -> Result<(), Error> {
    let (w, h) = (19, 13);
    let tir = noise(w * h, 3, 256);
    for variant in [Variant::Classic, Variant::Flight] {
        let p = AdfParams { variant, ..AdfParams::default() };
        let level = [0u8, 77][usize::from(variant == Variant::Flight)];
        let flat = std::vec![level; w * h];
        let mut out = [(); 2].map(|_| std::vec![0i32; w * h]);
        for (band, a) in
            [Band::Level(level), Band::Frame(FrameRef::new(&flat, w, h)?)].into_iter().zip(&mut out)
        {
            let mut work = std::vec![0i32; TABLE_WORDS + 4096];
            diffuse_pair(band, Band::Frame(FrameRef::new(&tir, w, h)?), (w, h), &p, a, &mut work)?;
        }
        assert_eq!(out[0], out[1]);
        assert!(out[0].iter().all(|&v| lo(v) == i32::from(level) << STATE_BITS), "a constant stays constant");
    }
    Ok(())
}

/// Selects a row-loop form on `d`: 0 the portable loop, 1 AVX-512, 2 AVX2, 3 NEON; `false`
/// when this CPU or target has no such form.
fn select_form(d: &mut Diffusion, form: u8) -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        d.avx512 = form == 1 && crate::cpu::has_avx512bw();
        d.avx2 = form == 2 && crate::cpu::has_avx2() && d.avx2_tables.is_some();
    }
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    {
        d.neon = form == 3 && crate::cpu::has_neon() && d.neon_tables.is_some();
    }
    match form {
        #[cfg(target_arch = "x86_64")]
        1 => d.avx512,
        #[cfg(target_arch = "x86_64")]
        2 => d.avx2,
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        3 => d.neon,
        0 => true,
        _ => false,
    }
}

/// The SIMD row loops (AVX-512, AVX2 on x86-64; NEON on AArch64, under `qemu-aarch64` in CI)
/// against the portable one (table and function) on random rows: every state in range, north
/// sums anywhere in their range, every κ class, widths around the blocks.
#[test]
fn simd_rows_equal_the_portable_rows() {
    let mut seed = 99u32;
    let mut next = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        seed
    };
    let mut table = std::vec![0i32; TABLE_WORDS];
    let mut compared = 0;
    for kappa in [1u16, 2, 7, 30, 100, 255] {
        for dt_milli in [1u16, 150, 250] {
            let mut d = Diffusion::new(&params(kappa, dt_milli));
            let Some(t) = table_view(&mut table) else { return };
            d.fx.tabulate(t);
            let t: &[i16] = t;
            for w in [1usize, 3, 4, 5, 7, 8, 9, 15, 16, 17, 32, 47, 64] {
                let mut state = || pack((next() >> 17) as i32, (next() >> 17) as i32);
                let p: Vec<i32> = (0..w + 2).map(|_| state()).collect();
                let q: Vec<i32> = (0..w + 2).map(|_| state()).collect();
                // North sums as the pipeline forms them: |n| ≤ 4·MAX_FLUX.
                let mut sum = || (next() % (8 * MAX_FLUX as u32 + 1)) as i32 - 4 * MAX_FLUX;
                let north: Vec<i32> = (0..w + 2).map(|_| pack(sum(), sum())).collect();
                let mut results = Vec::new();
                for (form, table) in [(0, Some(t)), (0, None), (1, None), (2, None), (3, None)] {
                    if !select_form(&mut d, form) {
                        continue;
                    }
                    let (mut n, mut o) = (north.clone(), std::vec![0i32; w]);
                    d.row(table, &p, &q, &mut n, &mut o);
                    results.push((n, o));
                }
                for r in &results[1..] {
                    assert_eq!(r, &results[0], "kappa {kappa} dt {dt_milli} w {w}");
                }
                compared += results.len() - 2;
            }
        }
    }
    // Not vacuous where a SIMD form exists.
    if cfg!(all(target_arch = "aarch64", target_feature = "neon"))
        || crate::cpu::isa() != crate::cpu::Isa::Portable
    {
        assert!(compared > 0, "no SIMD row loop was compared");
    }
}

/// The host's row loops at 1024² (`cargo test --release -p fusion-nostd --lib
/// row_loop_times -- --ignored --nocapture`): the AVX-512 loop, the AVX2 loop (what an x86-64
/// host without AVX-512 runs) and the portable loop on the table, median of 5, on two frame
/// pairs: uniform noise (every neighbour difference anywhere in 0..256: the AVX2 loop's worst
/// case) and a smooth scene (a slow wave with a sharp-edged disc: most differences small).
#[cfg(target_arch = "x86_64")]
#[test]
#[ignore = "measurement, prints the times"]
fn row_loop_times() -> Result<(), Error> {
    let (w, h) = (1024, 1024);
    let scene = |phase: f64| -> Vec<u8> {
        (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64, (i / w) as f64);
                let disc = if (x - 500.0).hypot(y - 480.0) < 300.0 { 60.0 } else { 0.0 };
                (100.0 + 60.0 * (x / 40.0 + phase).sin() * (y / 55.0).cos() + disc) as u8
            })
            .collect()
    };
    let frames = [("noise", noise(w * h, 5, 256), noise(w * h, 6, 256)), ("smooth", scene(0.0), scene(1.0))];
    let p = AdfParams::default();
    let (mut a, mut work) = (std::vec![0i32; w * h], std::vec![0i32; stream_words(w, &p)]);
    for (frame, sv, st) in &frames {
        let (vis, tir) = (Band::Frame(FrameRef::new(sv, w, h)?), Band::Frame(FrameRef::new(st, w, h)?));
        for (v512, v2) in [(true, false), (false, true), (false, false)] {
            let mut d = Diffusion::new(&p);
            d.avx512 = v512 && crate::cpu::has_avx512bw();
            d.avx2 = v2 && crate::cpu::has_avx2();
            let mut times: Vec<f64> = (0..5)
                .map(|_| {
                    let t = std::time::Instant::now();
                    let r = diffuse_with(d, vis, tir, (w, h), p.iterations, &mut a, &mut work);
                    assert!(r.is_ok());
                    t.elapsed().as_secs_f64() * 1e3
                })
                .collect();
            times.sort_by(f64::total_cmp);
            let name = if d.avx512 {
                "AVX-512"
            } else if d.avx2 {
                "AVX2"
            } else {
                "portable on the table"
            };
            std::println!("diffusion 1024², {frame} frames, {name} loop: median {:.2} ms", times[2]);
        }
    }
    Ok(())
}

/// One iteration on a 1×1 frame, by hand: the 8 neighbours are outside (zero padding), so
/// `u ← u − Δt·6·u·exp(−(u/κ)²)`.
#[test]
fn one_pixel_one_iteration_by_hand() -> Result<(), Error> {
    let p = AdfParams { variant: Variant::Classic, iterations: 1, ..AdfParams::default() };
    for v in [0u8, 10, 30, 60, 255] {
        let src = [v];
        let (mut a, mut work) = ([0i32; 1], [0i32; 1]);
        let band = Band::Frame(FrameRef::new(&src, 1, 1)?);
        diffuse_pair(band, band, (1, 1), &p, &mut a, &mut work)?;
        let u = f64::from(v);
        let want = u - 0.15 * 6.0 * u * libm::exp(-(u / 30.0) * (u / 30.0));
        for got in [lo(a[0]), hi(a[0])] {
            let got = f64::from(got) / 128.0;
            // 12 flux roundings of ½ state unit (1/256 level) each and the function's error.
            assert!((got - want).abs() < 7.0 / 128.0, "{v}: {got} vs {want}");
        }
    }
    Ok(())
}
