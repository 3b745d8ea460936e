extern crate std;
use super::super::round_away_sat_u8;
use super::*;

/// Deterministic test frames with `levels` grey levels (also used by `diffusion`'s tests).
pub(super) fn noise(n: usize, seed: u32, levels: u32) -> std::vec::Vec<u8> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            ((s >> 24) % levels) as u8 * (255 / (levels - 1).max(1)) as u8
        })
        .collect()
}

#[test]
fn raw_to_u8_is_the_matlab_cast() {
    let mut v = i32::MIN;
    loop {
        assert_eq!(raw_to_u8(v), round_away_sat_u8(i64::from(v), RAW_FRAC_BITS), "{v}");
        match v.checked_add(4093) {
            Some(n) => v = n,
            None => break,
        }
    }
    for v in [i32::MAX, i32::MAX - 1, -1, 0, 1, (1 << 15) - 1, 1 << 15, 255 << 16, (255 << 16) + (1 << 15)] {
        assert_eq!(raw_to_u8(v), round_away_sat_u8(i64::from(v), RAW_FRAC_BITS), "{v}");
    }
}

/// The chunk moments against `i128` sums, at the extremes of the detail range (every
/// `|D|` = 32767 over a whole chunk) and on noise.
#[test]
fn chunk_moments_are_exact() {
    let n = COV_CHUNK;
    let cases = [
        (std::vec![0u8; n], std::vec![255u8; n], std::vec![diffusion::pack(32767, 0); n]),
        (std::vec![255u8; n], std::vec![0u8; n], std::vec![diffusion::pack(0, 32767); n]),
        (
            noise(n, 5, 256),
            noise(n, 6, 256),
            noise(n, 7, 256)
                .iter()
                .map(|&v| diffusion::pack(i32::from(v) << 7, (3 * i32::from(v)) << 5))
                .collect(),
        ),
    ];
    for (iv, it, a) in cases {
        let mut want = [0i128; 5];
        for ((&iv, &it), &a) in iv.iter().zip(&it).zip(&a) {
            let d_vis = i128::from(iv) * 128 - i128::from(diffusion::lo(a));
            let d_ir = i128::from(it) * 128 - i128::from(diffusion::hi(a));
            for (s, v) in want.iter_mut().zip([d_ir, d_vis, d_ir * d_ir, d_ir * d_vis, d_vis * d_vis]) {
                *s += v;
            }
        }
        assert_eq!(chunk_moments(&iv, &it, &a), want);
    }
}

/// The fused value against the formula in `f64` (`½(A_IR + A_VIS) + D_VIS + p·(D_IR − D_VIS)`
/// in grey levels, rounded half up to Q16): equal wherever the `f64` value is not within
/// 10⁻⁶ of a rounding tie, for weights from the flight range to the classic ±128.
#[test]
fn fused_value_is_the_formula_rounded() {
    let mut s = 3u32;
    let mut next = || {
        s = s.wrapping_mul(1664525).wrapping_add(1013904223);
        s
    };
    for k in 0..200_000 {
        let (iv, it) = ((next() >> 24) as u8, (next() >> 24) as u8);
        let a = diffusion::pack((next() >> 17) as i32, (next() >> 17) as i32);
        let p: i64 = match k % 4 {
            0 => i64::from(next() >> 2),
            1 => -i64::from(next() >> 1),
            2 => [128i64 << 30, -(128i64 << 30), 0, 1 << 30][(next() >> 30) as usize],
            _ => i64::from(next()) << (next() >> 28),
        };
        let p = p.clamp(-(128 << 30), 128 << 30);
        let (d_vis, d_ir) = details(iv, it, a);
        let lv = |x: i32| f64::from(x) / 128.0;
        let pf = p as f64 / f64::from(1u32 << 30);
        let f = 0.5 * (lv(diffusion::hi(a)) + lv(diffusion::lo(a))) + lv(d_vis) + pf * (lv(d_ir) - lv(d_vis));
        let q = f * 65536.0;
        if (q - q.floor() - 0.5).abs() < 1e-6 {
            continue;
        }
        let want = (q + 0.5).floor().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
        assert_eq!(fused(p, iv, it, a), want, "p {p} iv {iv} it {it} a {a:#x}");
        if let Ok(p32) = i32::try_from(p) {
            assert_eq!(fused32(p32, iv, it, a), want, "p {p} iv {iv} it {it} a {a:#x}");
        }
    }
}

fn f64_weight(a: f64, b: f64, c: f64) -> f64 {
    let theta = 0.5 * libm::atan2(2.0 * b, a - c);
    let (v1, v2) = (libm::cos(theta), libm::sin(theta));
    v1 / (v1 + v2)
}

#[test]
fn kl_weights_against_the_closed_form() {
    let one = (1i64 << 30) as f64;
    for (a, b, c) in
        [(5i128, 2i128, 3i128), (1, 0, 4), (4, 0, 1), (100, 99, 100), (7, 3, 7), (1 << 90, 1 << 88, 1 << 89)]
    {
        for variant in [Variant::Classic, Variant::Flight] {
            let w = kl_weight(a, b, c, variant);
            let want = f64_weight(a as f64, b as f64, c as f64);
            assert!(
                (w.p_ir_q30 as f64 / one - want).abs() < 1e-8,
                "{a} {b} {c}: {} vs {want}",
                w.p_ir_q30 as f64 / one
            );
            assert_eq!(w.guards, Guards::NONE);
        }
    }
}

#[test]
fn kl_weight_guards() {
    let one = 1i64 << 30;
    // Zero covariance: MATLAB's eig gives the identity, first column → p_IR = 1 (classic);
    // flight ½.
    let z = kl_weight(0, 0, 0, Variant::Classic);
    assert_eq!(z.p_ir_q30, one);
    assert!(z.guards.contains(Guards::ADF_ZERO_COVARIANCE));
    assert_eq!(kl_weight(0, 0, 0, Variant::Flight).p_ir_q30, one / 2);
    // Equal variances, negatively correlated: v = (1, −1), v₁ + v₂ = 0.
    let n = kl_weight(9, -4, 9, Variant::Classic);
    assert_eq!(n.p_ir_q30, one / 2);
    assert!(n.guards.contains(Guards::ADF_DEGENERATE_EIGENVECTOR));
    let nf = kl_weight(9, -4, 9, Variant::Flight);
    assert_eq!(nf.p_ir_q30, one / 2);
    assert!(nf.guards.contains(Guards::ADF_WEIGHT_CLAMPED.with(Guards::ADF_DEGENERATE_EIGENVECTOR)));
    // Negatively correlated, unequal variances: published weights leave [0, 1].
    let c = kl_weight(9, -4, 3, Variant::Classic);
    let want = f64_weight(9.0, -4.0, 3.0);
    assert!(!(0.0..=1.0).contains(&want));
    assert!((c.p_ir_q30 as f64 / one as f64 - want).abs() < 1e-8);
    let f = kl_weight(9, -4, 3, Variant::Flight);
    assert!((0..=one).contains(&f.p_ir_q30));
    assert!(f.guards.contains(Guards::ADF_WEIGHT_CLAMPED));
    // Nearly degenerate: classic weights saturate at ±128.
    let s = kl_weight(1 << 40, -(1 << 40) + 1, (1 << 40) + 3, Variant::Classic);
    assert!(s.p_ir_q30.abs() <= 128 * one);
}

#[test]
fn isqrt_is_exact() {
    for n in [0u128, 1, 2, 3, 4, 15, 16, 17, u128::from(u64::MAX), (1 << 125) - 1, 1 << 124] {
        let r = isqrt_u128(n);
        assert!(r * r <= n && (r + 1) * (r + 1) > n, "{n}");
    }
}

#[test]
fn params_are_validated() {
    let bad = [
        (AdfParams { iterations: 0, ..AdfParams::default() }, "iterations"),
        (AdfParams { dt_milli: 251, ..AdfParams::default() }, "dt_milli"),
        (AdfParams { kappa: 0, ..AdfParams::default() }, "kappa"),
    ];
    for (p, name) in bad {
        assert_eq!(p.validate(), Err(Error::InvalidParameter { name }));
    }
    assert_eq!(AdfParams::default().validate(), Ok(()));
}

/// Random pixels of both bands and packed base layers (each half anywhere in `0..=32767`, the
/// first ones at the extremes), `n` of each.
#[cfg(target_arch = "x86_64")]
fn random_pixels(n: usize, seed: u32) -> (std::vec::Vec<u8>, std::vec::Vec<u8>, std::vec::Vec<i32>) {
    let mut s = seed;
    let mut next = move || {
        s = s.wrapping_mul(1664525).wrapping_add(1013904223);
        s >> 8
    };
    let extremes = [(0, 0), (32767, 0), (0, 32767), (32767, 32767)];
    let a = (0..n)
        .map(|i| {
            let (lo, hi) =
                extremes.get(i).copied().unwrap_or(((next() % 32768) as i32, (next() % 32768) as i32));
            diffusion::pack(lo, hi)
        })
        .collect();
    let iv = (0..n).map(|i| if i % 5 == 0 { 255 } else { next() as u8 }).collect();
    let it = (0..n).map(|i| if i % 7 == 0 { 0 } else { next() as u8 }).collect();
    (iv, it, a)
}

/// The AVX2 covariance loop gives the portable kernel's sums for the pixels it takes (whole
/// blocks of 16 up to the chunk), at every length around the blocks and the chunk.
#[cfg(target_arch = "x86_64")]
#[test]
fn avx2_moments_are_exact() {
    if !crate::cpu::has_avx2() {
        return;
    }
    for (n, seed) in [(0, 1), (15, 2), (16, 3), (17, 4), (1000, 5), (COV_CHUNK, 6), (COV_CHUNK + 40, 7)] {
        let (iv, it, a) = random_pixels(n, seed);
        // SAFETY: the CPU has AVX2 (checked above).
        let (done, sums, squares) = unsafe { avx2::moments_blocks(&iv, &it, &a) };
        assert_eq!(done, n.min(COV_CHUNK) / 16 * 16, "n {n}");
        assert_eq!((sums, squares), moments_kernel(&iv[..done], &it[..done], &a[..done]), "n {n}");
    }
}

/// The AVX2 output row gives the portable kernel's bytes and saturation flag for the pixels it
/// takes (whole blocks of 32) and leaves the rest of the row alone, for weights across the
/// `i32` range (both flag values occur).
#[cfg(target_arch = "x86_64")]
#[test]
fn avx2_output_rows_are_exact() {
    if !crate::cpu::has_avx2() {
        return;
    }
    let mut flags = std::collections::BTreeSet::new();
    for p in
        [0, 1, -1, 1 << 29, 1 << 30, -(1 << 30), 123_456_789, -987_654_321, i32::MAX, i32::MIN + 1, i32::MIN]
    {
        for (n, seed) in [(0, 1), (31, 2), (32, 3), (33, 4), (100, 5), (1029, 6)] {
            let (iv, it, a) = random_pixels(n, seed ^ p as u32);
            let (mut got, mut want) = (std::vec![7u8; n], std::vec![7u8; n]);
            // SAFETY: the CPU has AVX2 (checked above).
            let (done, saturated) = unsafe { avx2::u8_blocks(p, &iv, &it, &a, &mut got) };
            assert_eq!(done, n / 32 * 32, "p {p} n {n}");
            let want_saturated = u8_kernel(p, &iv[..done], &it[..done], &a[..done], &mut want[..done]);
            assert_eq!((&got, saturated), (&want, want_saturated), "p {p} n {n}");
            if done > 0 {
                flags.insert(saturated);
            }
        }
    }
    assert_eq!(flags.len(), 2, "both saturation outcomes are exercised");
}
