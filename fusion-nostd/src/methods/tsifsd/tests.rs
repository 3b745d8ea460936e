extern crate std;
use super::super::round_away_sat_u8;
use super::*;
use crate::Scratch;

/// The 8-bit combine against the cast of the exact raw value, and its saturation flag,
/// on random pixels (huge and zero saliencies, every tap count, extreme box sums).
#[test]
fn combine_u8_is_the_cast_of_combine() {
    let mut s = 11u64;
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        s >> 17
    };
    for k in 0..400_000u32 {
        let n = 2 * (next() % 32) as i64 + 1;
        let taps = n * n;
        let (iv, ii) = ((next() & 255) as u8, (next() & 255) as u8);
        let sum = |r: u64| match r % 4 {
            0 => 0,
            1 => (255 * taps) as i32,
            _ => (r % (255 * taps as u64 + 1)) as i32,
        };
        let (sv, si) = (sum(next()), sum(next()));
        let sal = |r: u64| match k.wrapping_add(r as u32) % 5 {
            0 => 0,
            1 => r % 8161,
            2 => r >> (r % 47),
            3 => 1 << (r % 41),
            _ => r % (1 << 40),
        };
        let (sal_v, sal_i) = (sal(next()), sal(next()));
        let (raw, zero) = combine(iv, ii, sv, si, sal_v, sal_i, taps);
        let want = round_away_sat_u8(i64::from(raw), RAW_FRAC_BITS);
        let want_sat = !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&raw);
        let got = combine_u8(iv, ii, sv, si, sal_v, sal_i, taps);
        assert_eq!(got, (want, zero, want_sat), "{iv} {ii} {sv} {si} {sal_v} {sal_i} {taps}");
    }
}

/// Small weights, every pixel pair class and a dense grid of box sums, exhaustively: the
/// ties and the saturation edges (`U = 0`, `k = 256`) of [`fused_u8`] included.
#[test]
fn combine_u8_on_a_dense_small_grid() {
    for taps in [1i64, 9, 25] {
        let top = 255 * taps as i32;
        for wv in 0..6u64 {
            for wi in 0..6u64 {
                for iv in [0u8, 1, 2, 127, 128, 254, 255] {
                    for ii in [0u8, 1, 128, 255] {
                        for sv in (0..=top).step_by((taps as usize * 7).max(1)) {
                            for si in (0..=top).step_by((taps as usize * 5).max(1)) {
                                let (raw, zero) = combine(iv, ii, sv, si, wv, wi, taps);
                                let want = round_away_sat_u8(i64::from(raw), RAW_FRAC_BITS);
                                let want_sat = !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&raw);
                                let got = combine_u8(iv, ii, sv, si, wv, wi, taps);
                                assert_eq!(
                                    got,
                                    (want, zero, want_sat),
                                    "{iv} {ii} {sv} {si} {wv} {wi} {taps}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}

/// `U = 0` with `2¹⁶ | den`: `N = −den − den/2¹⁶` (σ = 2¹⁷, taps = 1), the raw value is
/// `round(−32768.5) = −32769`, saturated low although `k = 0`.
#[test]
fn combine_u8_low_saturation_edge() {
    let (raw, _) = combine(253, 0, 0, 2, 257, 130815, 1);
    assert_eq!(raw, -32769);
    assert_eq!(combine_u8(253, 0, 0, 2, 257, 130815, 1), (0, false, true));
    let (raw, zero) = combine(253, 0, 0, 2, 257, 130815, 9);
    let sat = !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(&raw);
    assert_eq!(combine_u8(253, 0, 0, 2, 257, 130815, 9), (round_away_sat_u8(i64::from(raw), 16), zero, sat));
}

/// Both forms of [`fused_u8`] (the `i32` one runs only on the 32-bit targets) on small
/// weights, and the `f64` quotient against the integer division.
#[test]
fn small_and_wide_forms_agree() {
    let mut s = 77u64;
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        s >> 16
    };
    for k in 0..300_000u32 {
        let n = 2 * (next() % 32) as u32 + 1;
        let taps = n * n;
        let top = 255 * taps as u64 + 1;
        let (sv, si) = ((next() % top) as i32, (next() % top) as i32);
        let (iv, ii) = ((next() & 255) as u8, (next() & 255) as u8);
        let (mut wv, mut wi) = ((next() % (1 << 13)) as u32, (next() % (1 << 13)) as u32);
        if k % 7 == 0 {
            (wv, wi) = (wv % 3, wi % 3);
        }
        if wv + wi == 0 {
            wv = 1;
        }
        assert_eq!(
            fused_u8_small(iv, ii, sv, si, wv, wi, taps),
            fused_u8_wide(iv, ii, sv, si, wv, wi, taps),
            "{iv} {ii} {sv} {si} {wv} {wi} {taps}"
        );
        let v = (next() >> (next() % 28)).clamp(1, (1 << 37) - 1);
        let u = (next() % 256) * v + next() % v;
        assert_eq!(u64::from(quotient(u, v)), u / v, "{u} {v}");
        assert_eq!(u64::from(div_small(u, v)), u / v, "{u} {v}");
    }
}

#[test]
fn div_small_is_exact() {
    let mut s = 5u64;
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        s
    };
    for _ in 0..1_000_000 {
        let v = (next() >> (11 + next() % 53)).max(1);
        let k = next() % 256;
        let u = k * v + next() % v;
        assert_eq!(u64::from(div_small(u, v)), u / v, "{u} {v}");
    }
    for v in [1u64, 2, 3, (1 << 24) - 1, 1 << 24, (1 << 24) + 1, (1 << 52) - 1] {
        for u in [0, v - 1, v, 255 * v, 256 * v - 1] {
            assert_eq!(u64::from(div_small(u, v)), u / v, "{u} {v}");
        }
    }
}

/// The 8-bit path equals the cast of the raw path on whole frames (both variants; a
/// checkerboard drives the classic output far out of range).
#[test]
fn u8_path_is_the_cast_of_the_raw_path() -> Result<(), Error> {
    let (w, h) = (37usize, 29usize);
    let mut s = 1u32;
    let mut frame = |checker: bool| -> std::vec::Vec<u8> {
        (0..w * h)
            .map(|i| {
                s = s.wrapping_mul(1664525).wrapping_add(1013904223);
                if checker { if (i % w + i / w) % 2 == 0 { 255 } else { 0 } } else { (s >> 24) as u8 }
            })
            .collect()
    };
    for (vis, tir) in [
        (frame(false), frame(false)),
        (frame(true), frame(false)),
        (std::vec![9u8; w * h], std::vec![9u8; w * h]),
    ] {
        for variant in [Variant::Classic, Variant::Flight] {
            for mean_size in [3u16, 35] {
                let params = TsifsdParams { variant, mean_size };
                let mut scratch = Scratch::<{ 37 * 29 }>::new();
                let mut raw = std::vec![0i32; w * h];
                let g_raw = fuse_tsifsd_raw(
                    FrameRef::new(&vis, w, h)?,
                    FrameRef::new(&tir, w, h)?,
                    FrameMut::new(&mut raw, w, h)?,
                    &params,
                    &mut scratch.view_mut(),
                )?;
                let mut out = std::vec![0u8; w * h];
                let g = fuse_tsifsd(
                    FrameRef::new(&vis, w, h)?,
                    FrameRef::new(&tir, w, h)?,
                    FrameMut::new(&mut out, w, h)?,
                    &params,
                    &mut scratch.view_mut(),
                )?;
                let want: std::vec::Vec<u8> =
                    raw.iter().map(|&v| round_away_sat_u8(i64::from(v), RAW_FRAC_BITS)).collect();
                assert_eq!(out, want);
                let sat = raw.iter().any(|v| !(-(1 << 15)..(255 << 16) + (1 << 15)).contains(v));
                assert_eq!(g, if sat { g_raw | Guards::OUTPUT_SATURATED } else { g_raw });
            }
        }
    }
    Ok(())
}

/// The flight 8-bit kernel against the general path (the cast of the exact value) on
/// random, checkerboard, flat and two-level frames of many shapes and every window size
/// class: the same pixels and the same guards.
#[test]
fn flight_kernel_equals_general_path() -> Result<(), Error> {
    let mut s = 99u32;
    let mut next = move || {
        s = s.wrapping_mul(1664525).wrapping_add(1013904223);
        s >> 8
    };
    for (k, (w, h)) in
        [(1usize, 1usize), (1, 7), (7, 1), (2, 2), (3, 5), (2, 40), (37, 29), (300, 4), (257, 3), (600, 9)]
            .into_iter()
            .enumerate()
    {
        for pattern in 0..5u32 {
            let mut frame = |salt: u32| -> std::vec::Vec<u8> {
                (0..w * h)
                    .map(|i| {
                        let r = next();
                        match pattern {
                            0 => r as u8,
                            1 => {
                                if (i % w + i / w + salt as usize).is_multiple_of(2) {
                                    255
                                } else {
                                    0
                                }
                            }
                            2 => 77,
                            3 => {
                                if r % 3 == 0 {
                                    255
                                } else {
                                    0
                                }
                            }
                            _ => ((i % w) * 3 + salt as usize * 40) as u8 ^ (r % 4) as u8,
                        }
                    })
                    .collect()
            };
            let (vis, tir) = (frame(0), frame(1));
            let (vis, tir) = (FrameRef::new(&vis, w, h)?, FrameRef::new(&tir, w, h)?);
            for mean_size in [1u16, 3, 35, 63] {
                let params = TsifsdParams { variant: Variant::Flight, mean_size };
                let radius = usize::from(mean_size / 2);
                let taps = i64::from(mean_size) * i64::from(mean_size);
                let (mut tmp, mut sv, mut si) =
                    (std::vec![0i32; w * h], std::vec![0i32; w * h], std::vec![0i32; w * h]);
                box_sum_u8(vis, radius, params.mean_border(), &mut tmp, &mut sv)?;
                box_sum_u8(tir, radius, params.mean_border(), &mut tmp, &mut si)?;
                let (mut want, mut got) = (std::vec![0u8; w * h], std::vec![0u8; w * h]);
                let g_want = saliency_reconstruct(
                    vis,
                    tir,
                    &sv,
                    &si,
                    taps,
                    false,
                    Out::U8(FrameMut::new(&mut want, w, h)?),
                );
                // The ring alone (dirty), whatever the height.
                let (mut cols, mut lanes) =
                    (std::vec![7i32; w + 2 * radius + 1], std::vec![-3i32; lane_ring_rows(radius) * w]);
                let out = FrameMut::new(&mut got, w, h)?;
                let g_got = flight_u8(vis, tir, taps as u32, radius, &mut cols, &mut lanes, out, 0);
                assert_eq!(
                    (&got, g_got),
                    (&want, g_want),
                    "case {k} {w}x{h} pattern {pattern} n {mean_size}"
                );
                // Any row range gives those rows of the whole-frame run (the strip form).
                for (y0, n) in [(1, h - 1), (h / 2, h - h / 2), (h - 1, 1), (h / 3, 1.max(h / 3))] {
                    if n == 0 || y0 + n > h {
                        continue;
                    }
                    let mut rows = std::vec![0u8; w * n];
                    let out = FrameMut::new(&mut rows, w, n)?;
                    flight_u8(vis, tir, taps as u32, radius, &mut cols, &mut lanes, out, y0);
                    assert_eq!(rows[..], want[y0 * w..(y0 + n) * w], "rows {y0}+{n} {w}x{h} n {mean_size}");
                }
            }
        }
    }
    Ok(())
}

/// The divisions of the wide chunk form and of `ByC` against integer division, at and around
/// every multiple that matters: `⌊n/c⌋` for every `c = 2·n²` (odd `n ≤ 63`) and `n` up to
/// 2²⁸; `⌊n/σ⌋` for every `σ ≤ 16320` and quotients up to 512.
#[test]
fn division_helpers_are_exact() {
    for side in (1u32..=63).step_by(2) {
        let c = 2 * side * side;
        let by_c = ByC(NonZeroU32::new(c).unwrap());
        let inv_c = 1.0 / f64::from(c);
        let magic = MagicC::new(NonZeroU32::new(c).unwrap());
        let check = |n: u32| {
            assert_eq!(div_c_f64(n, inv_c), n / c, "n {n} c {c}");
            assert_eq!(magic.div(n), n / c, "n {n} c {c}");
            assert_eq!(by_c.div(n), n / c, "n {n} c {c}");
        };
        for k in (0..(1u32 << 28) / c).step_by(997).chain([(1 << 28) / c - 1]) {
            for n in [k * c, k * c + 1, k * c + c - 1, (k + 1) * c - 1] {
                if n < 1 << 28 {
                    check(n);
                }
            }
        }
    }
    // The multiplication's bound holds for every divisor below 2¹⁴, not only the window's;
    // from c = 2 on the multiplier fits the NEON chunk's `sqdmulh` (⌊2·n·m / 2³²⌋, then the
    // shift by s − 31), modelled here.
    for c in 1u32..1 << 14 {
        let magic = MagicC::new(NonZeroU32::new(c).unwrap());
        assert!(magic.s >= 31 && (c < 2 || magic.m <= i32::MAX as u64), "c {c}: {magic:?}");
        let top = (1u32 << 28) - 1;
        for n in [0, 1, c - 1, c, c + 1, top / c * c - 1, top / c * c, top - 1, top] {
            assert_eq!(magic.div(n), n / c, "n {n} c {c}");
            if c >= 2 {
                let high = (2 * i64::from(n) * magic.m as i64) >> 32;
                assert_eq!((high >> (magic.s - 31)) as u32, n / c, "sqdmulh n {n} c {c}");
            }
        }
    }
    for sigma in 1u32..=16320 {
        for k in [0u32, 1, 2, 127, 128, 255, 383, 510, 511, 512] {
            for n in [k * sigma, (k * sigma).saturating_sub(1), k * sigma + sigma - 1, k * sigma + 1] {
                let want = n / sigma;
                assert_eq!(div_sigma_f32(n, sigma), want, "n {n} sigma {sigma}");
                assert_eq!(div_sigma(n, NonZeroU32::new(sigma).unwrap()), want, "n {n} sigma {sigma}");
            }
        }
    }
}

/// The wide kernel form (x86-64: the wide chunk; AArch64: the NEON chunk and row loops) gives
/// the portable form's bytes and flags: random frames,
/// flat ones (the zero-saliency guard), and full-swing checkerboards and stripes (the
/// largest gradients, σ up to 16320, and saturated outputs), several widths and row ranges.
#[test]
fn wide_and_portable_chunks_agree() -> Result<(), Error> {
    let mut s = 0x2545_F491u32;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        s
    };
    for (w, h) in [(300usize, 41usize), (257, 40), (600, 45), (64, 38)] {
        for pattern in 0..5 {
            let mut frame = |salt: usize| -> std::vec::Vec<u8> {
                (0..w * h)
                    .map(|i| {
                        let (x, y) = (i % w, i / w);
                        match pattern {
                            0 => next() as u8,
                            1 => 90,
                            2 => (((x + y + salt) % 2) * 255) as u8,
                            3 => (((x / 3 + salt) % 2) * 255) as u8 ^ ((y % 2) * 255) as u8,
                            _ => {
                                if next() % 7 == 0 {
                                    255
                                } else {
                                    (x * salt) as u8
                                }
                            }
                        }
                    })
                    .collect()
            };
            let (vis, tir) = (frame(1), frame(2));
            let (vis, tir) = (FrameRef::new(&vis, w, h)?, FrameRef::new(&tir, w, h)?);
            for mean_size in [1u16, 3, 35] {
                let radius = usize::from(mean_size / 2);
                let taps = u32::from(mean_size) * u32::from(mean_size);
                let run = |wide: bool, y0: usize| {
                    let mut cols = std::vec![0i32; w + 2 * radius + 1];
                    let mut lanes = std::vec![0i32; lane_ring_rows(radius) * w];
                    let mut out = std::vec![0u8; w * (h - y0)];
                    let f = FrameMut::new(&mut out, w, h - y0).unwrap();
                    let flags = if wide {
                        flight_u8_kernel::<true>(vis, tir, taps, radius, &mut cols, &mut lanes, f, y0)
                    } else {
                        flight_u8_kernel::<false>(vis, tir, taps, radius, &mut cols, &mut lanes, f, y0)
                    };
                    (out, flags)
                };
                for y0 in [0, h / 2] {
                    assert_eq!(
                        run(true, y0),
                        run(false, y0),
                        "{w}x{h} pattern {pattern} n {mean_size} y0 {y0}"
                    );
                }
            }
        }
    }
    Ok(())
}

/// The portable `column_step` against a model of the Arm `smlad` pair.
#[test]
fn column_step_matches_the_smlad_model() {
    let smlad = |a: i32, b: i32, acc: i32| {
        let lo = |v: i32| i32::from(v as i16);
        let hi = |v: i32| i32::from((v >> 16) as i16);
        acc + lo(a) * lo(b) + hi(a) * hi(b)
    };
    let mut s = 3u32;
    let mut next = move || {
        s = s.wrapping_mul(1664525).wrapping_add(1013904223);
        (s >> 24) as u8
    };
    for k in 0..100_000i32 {
        let (e, l) = (lane_pair(next(), next()), lane_pair(next(), next()));
        let col = (k - 50_000) * 9;
        let [up, down] = LANE_WEIGHTS;
        assert_eq!(column_step(col, e, l, LANE_WEIGHTS), smlad(l, down, smlad(e, up, col)));
    }
}

/// 3×3 frames, 3×3 circular mean (every window is the whole frame): VIS has one 90 in the
/// centre, TIR is black. B_VIS = 10, every median 0, S_VIS = 100, S_IR = 0, so w_VIS = 1
/// and F = ½·10 + (I_VIS − 10): 85 in the centre, −5 elsewhere.
#[test]
fn hand_computed_three_by_three() -> Result<(), Error> {
    let vis = [0u8, 0, 0, 0, 90, 0, 0, 0, 0];
    let tir = [0u8; 9];
    let params = TsifsdParams { variant: Variant::Classic, mean_size: 3 };
    let mut scratch = Scratch::<9>::new();
    let mut raw = [0i32; 9];
    let g = fuse_tsifsd_raw(
        FrameRef::new(&vis, 3, 3)?,
        FrameRef::new(&tir, 3, 3)?,
        FrameMut::new(&mut raw, 3, 3)?,
        &params,
        &mut scratch.view_mut(),
    )?;
    let want: [i32; 9] = core::array::from_fn(|i| if i == 4 { 85 << 16 } else { -5 << 16 });
    assert_eq!(raw, want);
    assert_eq!(g, Guards::NONE);
    let mut out = [7u8; 9];
    let g = fuse_tsifsd(
        FrameRef::new(&vis, 3, 3)?,
        FrameRef::new(&tir, 3, 3)?,
        FrameMut::new(&mut out, 3, 3)?,
        &params,
        &mut scratch.view_mut(),
    )?;
    assert_eq!(out, [0, 0, 0, 0, 85, 0, 0, 0, 0]);
    assert!(g.contains(Guards::OUTPUT_SATURATED));
    Ok(())
}

#[test]
fn combine_is_the_exact_rational() {
    // N = 9, Σ_VIS = 90, Σ_IR = 45, I = 20 / 3, saliencies 3 : 1.
    // F = (90 + 45)/18 + (3·(180 − 90) + 1·(27 − 45)) / (9·4) = 7.5 + 7 = 14.5
    let (v, zero) = combine(20, 3, 90, 45, 3, 1, 9);
    assert_eq!((v, zero), ((29 << 16) / 2, false));
    let (v, zero) = combine(20, 3, 90, 45, 0, 0, 9);
    assert_eq!((v, zero), ((23 << 16) / 2, true), "½, ½: (20 + 3)/2");
    // Scaling of huge saliencies keeps the ratio.
    let (v, _) = combine(20, 3, 90, 45, 3 << 38, 1 << 38, 9);
    assert_eq!(v, (29 << 16) / 2);
}

#[test]
fn params_are_validated() {
    for size in [0u16, 2, 64, 65] {
        let p = TsifsdParams { mean_size: size, ..TsifsdParams::default() };
        assert_eq!(p.validate(), Err(Error::InvalidParameter { name: "mean_size" }));
    }
    assert_eq!(TsifsdParams::default().validate(), Ok(()));
}
