extern crate std;
use super::*;

/// `bg_u8` against the saturating form over the background range (|bg| < 2²⁹).
#[test]
fn bg_u8_rounds_half_up_and_clamps() {
    let slow = |bg: i32| (bg.max(0).saturating_add(1 << (BG_BITS - 1)) >> BG_BITS).min(255);
    let mut bg = -(1i32 << 29);
    while bg < 1 << 29 {
        for d in [-1, 0, 1, (1 << 19) - 1, 1 << 19] {
            assert_eq!(bg_u8(bg + d), slow(bg + d), "{}", bg + d);
        }
        bg += 65_537;
    }
}

/// The tabulated step 12 against the per-pixel one, saturating gains included.
#[test]
fn tabulated_output_equals_direct_output() -> Result<(), Error> {
    let (w, h) = (61usize, 37usize);
    let mut s = 5u32;
    let mut next = || {
        s = s.wrapping_mul(1664525).wrapping_add(1013904223);
        (s >> 24) as u8
    };
    let vis: std::vec::Vec<u8> = (0..w * h).map(|_| next()).collect();
    let tir: std::vec::Vec<u8> = (0..w * h).map(|_| next()).collect();
    let r: std::vec::Vec<i32> = tir.iter().map(|&t| (i32::from(t) - i32::from(next())).max(0)).collect();
    for (g_q, b_q) in
        [(1i64 << 39, 1i64 << 40), (7 << 37, 3 << 41), (1 << 40, 1 << 52), (0, 0), (123_456_789, -5)]
    {
        let mut direct = std::vec![0u8; w * h];
        let sat_d = output_pass(
            FrameRef::new(&vis, w, h)?,
            FrameRef::new(&tir, w, h)?,
            &r,
            FrameMut::new(&mut direct, w, h)?,
            g_q,
            b_q,
            None,
        );
        let mut table = std::vec![0i32; ADD_TABLE_LEN];
        let mut tabulated = std::vec![0u8; w * h];
        let sat_t = output_pass(
            FrameRef::new(&vis, w, h)?,
            FrameRef::new(&tir, w, h)?,
            &r,
            FrameMut::new(&mut tabulated, w, h)?,
            g_q,
            b_q,
            Some(&mut table),
        );
        assert_eq!((direct, sat_d), (tabulated, sat_t), "{g_q} {b_q}");
    }
    Ok(())
}

#[test]
fn the_quadtree_grid_follows_the_crop() {
    let p = IfevipParams::default(); // D = 512, leaf 32
    let d = |crop: usize, frame: usize| p.on_crop(crop, frame).quad_norm_dim;
    // The whole frame keeps D; 512·290/1024 = 145 is nearer 128 than 256 (ratio 1.13 vs 1.77);
    // 512·400/1024 = 200 ≥ √2·128 = 181 → 256; tiny crops stop at 8; never above D.
    assert_eq!(d(1024, 1024), 512);
    assert_eq!(d(290, 1024), 128);
    assert_eq!(d(400, 1024), 256);
    assert_eq!(d(3, 1024), 8);
    assert_eq!(d(700, 640), 512);
    // The leaf side stays valid: within D′/16..=D′.
    for crop in [3, 17, 64, 290, 400, 1024] {
        let q = p.on_crop(crop, 1024);
        assert!(q.validate().is_ok(), "{crop}: {q:?}");
        assert_eq!(q.quad_min_dim, 32u16.clamp((q.quad_norm_dim / 16).max(4), q.quad_norm_dim));
    }
}
