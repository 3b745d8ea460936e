use super::*;
extern crate std;

#[test]
fn weights_sum_to_one_and_identity_at_scale_one() -> Result<(), Error> {
    let mut buf = [0i32; 8192];
    for (n_in, n_out) in [(5usize, 5usize), (1, 7), (7, 1), (332, 512), (630, 512), (512, 2), (3, 512)] {
        let taps = build(n_in, n_out, &mut buf)?;
        let mut rows = 0;
        for (start, ws) in taps.iter() {
            rows += 1;
            assert_eq!(ws.iter().map(|&w| i64::from(w)).sum::<i64>(), 1 << WEIGHT_BITS, "{n_in}->{n_out}");
            assert!(start + ws.len() <= n_in);
        }
        assert_eq!(rows, n_out);
    }
    let taps = build(5, 5, &mut buf)?;
    for (x, (start, ws)) in taps.iter().enumerate() {
        let ones: i32 = ws.iter().filter(|&&w| w == 1 << WEIGHT_BITS).count() as i32;
        assert_eq!(ones, 1);
        let pos = ws.iter().position(|&w| w == 1 << WEIGHT_BITS).unwrap_or(usize::MAX);
        assert_eq!(start + pos, x);
    }
    Ok(())
}

/// The period reuse gives the table of the row-by-row exact computation.
#[test]
fn periodic_rows_equal_computed_rows() -> Result<(), Error> {
    let mut a = std::vec![0i32; 1 << 16];
    let mut b = std::vec![0i32; 1 << 16];
    for (n_in, n_out) in [
        (1024usize, 512usize),
        (512, 1024),
        (512, 512),
        (301, 512),
        (512, 232),
        (7, 3),
        (3, 7),
        (1, 9),
        (640, 480),
    ] {
        let reused = build_with(n_in, n_out, &mut a, true)?;
        let (s1, t1) = (reused.stride, reused.table.to_vec());
        let exact = build_with(n_in, n_out, &mut b, false)?;
        assert_eq!((s1, t1), (exact.stride, exact.table.to_vec()), "{n_in} -> {n_out}");
    }
    Ok(())
}

/// The 8-tap row pass (AVX2 on x86-64, NEON on AArch64) against the portable one (both output
/// kinds, ragged widths).
#[test]
fn simd_rows_equal_portable_rows() -> Result<(), Error> {
    let mut buf = std::vec![0i32; 1 << 16];
    let mut seed = 7u32;
    let mut tested = 0;
    for (n_in, n_out, h) in [(1024usize, 512usize, 3usize), (64, 35, 2), (40, 21, 1)] {
        let taps = build(n_in, n_out, &mut buf)?;
        if taps.stride() != 10 {
            continue;
        }
        let src: std::vec::Vec<i32> = (0..n_in * h)
            .map(|_| {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                (seed >> 4) as i32 - (1 << 27)
            })
            .collect();
        for out in [Output::U8, Output::Same] {
            let mut a = std::vec![0i32; n_out * h];
            let mut b = std::vec![1i32; n_out * h];
            pass_rows(FrameRef::new(&src, n_in, h)?, &taps, FrameMut::new(&mut a, n_out, h)?, out);
            rows_kernel(FrameRef::new(&src, n_in, h)?, &taps, FrameMut::new(&mut b, n_out, h)?, out);
            assert_eq!(a, b, "{n_in}->{n_out} {out:?}");
            tested += 1;
        }
    }
    assert!(tested > 0, "no 8-tap table among the sizes");
    Ok(())
}

/// The 8-tap column pass (Armv7E-M assembly, NEON) against the portable one for the two forms
/// IFEVIP runs (`u8` → `U8`, `i32` → `Same`), widths around the 8-column blocks, and a table
/// whose last rows reach below the source (the SIMD forms decline it).
#[test]
fn simd_cols_equal_portable_cols() -> Result<(), Error> {
    let mut buf = std::vec![0i32; 1 << 16];
    let mut seed = 11u32;
    let mut next = move || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        seed
    };
    let mut tested = 0;
    for (n_in, n_out) in [(1024usize, 512usize), (64, 35), (40, 21), (17, 9)] {
        let taps = build(n_in, n_out, &mut buf)?;
        if taps.stride() != 10 {
            continue;
        }
        for w in [1usize, 7, 8, 9, 33] {
            let bytes: std::vec::Vec<u8> = (0..n_in * w).map(|_| (next() >> 24) as u8).collect();
            let words: std::vec::Vec<i32> = (0..n_in * w).map(|_| (next() >> 3) as i32 - (1 << 28)).collect();
            let mut a = std::vec![0i32; n_out * w];
            let mut b = std::vec![1i32; n_out * w];
            pass_cols(FrameRef::new(&bytes, w, n_in)?, &taps, FrameMut::new(&mut a, w, n_out)?, Output::U8);
            cols_kernel(FrameRef::new(&bytes, w, n_in)?, &taps, FrameMut::new(&mut b, w, n_out)?, Output::U8);
            assert_eq!(a, b, "u8 {n_in}->{n_out} width {w}");
            pass_cols(FrameRef::new(&words, w, n_in)?, &taps, FrameMut::new(&mut a, w, n_out)?, Output::Same);
            cols_kernel(
                FrameRef::new(&words, w, n_in)?,
                &taps,
                FrameMut::new(&mut b, w, n_out)?,
                Output::Same,
            );
            assert_eq!(a, b, "i32 {n_in}->{n_out} width {w}");
            // A source shorter than the table reaches: zero rows below it.
            let short = n_in - 3;
            let (bytes, words) = (&bytes[..short * w], &words[..short * w]);
            pass_cols(FrameRef::new(bytes, w, short)?, &taps, FrameMut::new(&mut a, w, n_out)?, Output::U8);
            cols_kernel(FrameRef::new(bytes, w, short)?, &taps, FrameMut::new(&mut b, w, n_out)?, Output::U8);
            assert_eq!(a, b, "u8 short {n_in}->{n_out} width {w}");
            pass_cols(FrameRef::new(words, w, short)?, &taps, FrameMut::new(&mut a, w, n_out)?, Output::Same);
            cols_kernel(
                FrameRef::new(words, w, short)?,
                &taps,
                FrameMut::new(&mut b, w, n_out)?,
                Output::Same,
            );
            assert_eq!(a, b, "i32 short {n_in}->{n_out} width {w}");
            tested += 1;
        }
    }
    assert!(tested > 0, "no 8-tap table among the sizes");
    Ok(())
}

#[test]
fn kernel_matches_keys_half() {
    // 2D³·cubic(σ/D) at σ/D = 0, 0.5, 1, 1.5, 2 with D = 8.
    let d = 8;
    let two_d3 = 2 * d * d * d;
    assert_eq!(kernel_num(0, d), two_d3);
    assert_eq!(kernel_num(4, d) * 16, two_d3 * 9); // cubic(0.5) = 0.5625
    assert_eq!(kernel_num(-8, d), 0);
    assert_eq!(kernel_num(12, d) * 16, -two_d3); // cubic(1.5) = −0.0625
    assert_eq!(kernel_num(16, d), 0);
}

#[test]
fn small_too_small_buffer_is_an_error() {
    let mut buf = [0i32; 8];
    assert!(matches!(build(630, 512, &mut buf), Err(Error::ScratchTooSmall { .. })));
}
