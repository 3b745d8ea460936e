//! The thermal front end (`fusion_nostd::thermal`): two-point correction, shutter re-levelling,
//! bad-pixel replacement and the column-noise filter against the f64 references written from
//! their definitions (`fusion_reference::thermal`), hand-computed tiny cases, the frame, strip
//! and row forms against each other, and bad tables and maps refused with nothing written.

use fusion_nostd::thermal::{
    BadPixelMap, ColumnFilter, ColumnParams, Correction, GAIN_FRAC_BITS, GAIN_ONE, NucTables, bad_map_bytes,
    column_filter_frame, correct_frame, correct_row, correct_strip, nuc_frame, shutter_update,
};
use fusion_nostd::{Error, FrameMut, FrameRef};
use fusion_reference::thermal as reference;
use render_host::noise::SplitMix64;

struct Rng(SplitMix64);
impl Rng {
    fn new(seed: u64) -> Self {
        Rng(SplitMix64::new(seed))
    }
    fn uniform(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Roughly normal: the sum of four uniforms.
    fn normal(&mut self, mean: f64, sigma: f64) -> f64 {
        let s: f64 = (0..4).map(|_| self.uniform()).sum();
        mean + sigma * (s - 2.0) * 3f64.sqrt()
    }
}

/// Factory-like tables: gains within ±6 % of one, offsets within ±600 counts.
fn tables(n: usize, rng: &mut Rng) -> (Vec<u16>, Vec<i16>) {
    let gain = (0..n).map(|_| (f64::from(GAIN_ONE) * rng.normal(1.0, 0.03)).round() as u16).collect();
    let offset = (0..n).map(|_| rng.normal(0.0, 300.0).round() as i16).collect();
    (gain, offset)
}

/// Raw counts: a smooth scene with a warm block, noise, in `bits` bits.
fn raw_frame(w: usize, h: usize, bits: u32, rng: &mut Rng) -> Vec<u16> {
    let full = f64::from((1u32 << bits) - 1);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let warm = x > w / 3 && x < 2 * w / 3 && y > h / 4 && y < 3 * h / 4;
            let level = if warm { 0.6 } else { 0.25 + 0.1 * y as f64 / h as f64 };
            rng.normal(level * full, 0.01 * full).round().clamp(0.0, full) as u16
        })
        .collect()
}

/// A map with scattered bad pixels (`fraction`), a 3×3 and a 4×2 cluster, a dead column and a
/// dead row; bits packed as the core wants them.
fn bad_map(w: usize, h: usize, fraction: f64, rng: &mut Rng) -> (Vec<bool>, Vec<u8>) {
    let mut bad: Vec<bool> = (0..w * h).map(|_| rng.uniform() < fraction).collect();
    let mut set = |x: usize, y: usize| {
        if x < w && y < h {
            bad[y * w + x] = true;
        }
    };
    for (x0, y0, cw, ch) in [(w / 4, h / 4, 3, 3), (w / 2, h / 5, 4, 2)] {
        for y in y0..y0 + ch {
            for x in x0..x0 + cw {
                set(x, y);
            }
        }
    }
    for y in 0..h {
        set(w - 3, y);
    }
    for x in 0..w {
        set(x, 2 * h / 3);
    }
    (bad.clone(), pack(&bad, w, h))
}

fn pack(bad: &[bool], w: usize, h: usize) -> Vec<u8> {
    let stride = w.div_ceil(8);
    let mut bits = vec![0u8; bad_map_bytes(w, h)];
    for y in 0..h {
        for x in 0..w {
            if bad[y * w + x] {
                bits[y * stride + x / 8] |= 1 << (x % 8);
            }
        }
    }
    bits
}

fn round_half_up(v: f64) -> f64 {
    (v + 0.5).floor()
}

fn real(gain: &[u16]) -> Vec<f64> {
    gain.iter().map(|&g| f64::from(g) / f64::from(1u32 << GAIN_FRAC_BITS)).collect()
}

#[test]
fn nuc_equals_the_f64_two_point_correction_rounded() {
    let mut rng = Rng::new(5);
    for (w, h, bits) in [(64, 48, 14), (37, 5, 16), (1, 1, 16), (640, 8, 14)] {
        let (gain, offset) = tables(w * h, &mut rng);
        let raw = raw_frame(w, h, bits, &mut rng);
        let t = NucTables::new(w, h, &gain, &offset).unwrap();
        let mut out = vec![0u16; w * h];
        nuc_frame(&t, FrameRef::new(&raw, w, h).unwrap(), FrameMut::new(&mut out, w, h).unwrap()).unwrap();
        let offs: Vec<f64> = offset.iter().map(|&o| f64::from(o)).collect();
        let r = reference::nuc(&raw, &real(&gain), &offs);
        for (i, (&c, &r)) in out.iter().zip(&r).enumerate() {
            assert_eq!(f64::from(c), round_half_up(r).clamp(0.0, 65_535.0), "{w}x{h} pixel {i}");
        }
    }
}

#[test]
fn hand_computed_nuc_and_replacement() {
    // Gains 1.5, 1, 0.75, 2 (Q2.14); offsets −10, 0, 3, 65 000-ish clamps.
    let gain = [24_576u16, GAIN_ONE, 12_288, 32_768];
    let offset = [-10i16, 0, 3, 32_000];
    let raw = [3u16, 7, 5, 40_000];
    let t = NucTables::new(4, 1, &gain, &offset).unwrap();
    let mut out = [0u16; 4];
    nuc_frame(&t, FrameRef::new(&raw, 4, 1).unwrap(), FrameMut::new(&mut out, 4, 1).unwrap()).unwrap();
    // 1.5·3 = 4.5 → 5 (half up), −10 → 0 (clamped); 7; 0.75·5 = 3.75 → 4, +3 = 7; 80 000 → 65 535.
    assert_eq!(out, [0, 7, 7, 65_535]);
    // A 3×3 frame, the centre and the right column's middle bad: the centre's valid neighbours
    // are 10, 20, 30, 40, 60, 80, 90 (seven: median 40); (2, 1)'s are 20, 30, 80, 90 (four: the
    // middle two 30 and 80 → 55).
    let raw = [10u16, 20, 30, 40, 999, 999, 60, 80, 90];
    let bits = [0u8, 0b110, 0];
    let stages = Correction { nuc: None, bad: Some(BadPixelMap::new(3, 3, &bits).unwrap()) };
    let mut out = [0u16; 9];
    correct_frame(&stages, None, FrameRef::new(&raw, 3, 3).unwrap(), FrameMut::new(&mut out, 3, 3).unwrap())
        .unwrap();
    assert_eq!(out, [10, 20, 30, 40, 40, 55, 60, 80, 90]);
    // A 5×3 frame whose middle three columns are bad: (1, 1) has the valid neighbours 1, 11,
    // 3 (median 3), (3, 1) has 2, 22, 4 (median 4); (2, 1) has none and takes the nearest valid
    // pixel of its row: (0, 1) and (4, 1) are both 2 away, the left one wins.
    let raw = [1u16, 0, 0, 0, 2, 11, 0, 0, 0, 22, 3, 0, 0, 0, 4];
    let bits = [0b0_1110u8, 0b0_1110, 0b0_1110];
    let stages = Correction { nuc: None, bad: Some(BadPixelMap::new(5, 3, &bits).unwrap()) };
    let mut out = [0u16; 15];
    correct_frame(&stages, None, FrameRef::new(&raw, 5, 3).unwrap(), FrameMut::new(&mut out, 5, 3).unwrap())
        .unwrap();
    assert_eq!(out[5..10], [11, 3, 11, 4, 22]);
}

#[test]
fn the_shutter_flattens_the_corrected_shutter_frame() {
    let mut rng = Rng::new(9);
    let (w, h) = (96, 64);
    let (gain, mut offset) = tables(w * h, &mut rng);
    // The offsets have drifted since calibration: each pixel by its own amount.
    let drifted: Vec<i16> = offset.iter().map(|&o| o + rng.normal(40.0, 25.0).round() as i16).collect();
    offset.copy_from_slice(&drifted);
    let shutter: Vec<u16> = (0..w * h).map(|_| rng.normal(5_000.0, 200.0).round() as u16).collect();
    let (bad, bits) = bad_map(w, h, 0.01, &mut rng);
    let map = BadPixelMap::new(w, h, &bits).unwrap();
    let before = offset.clone();
    let report =
        shutter_update(&gain, &mut offset, Some(&map), FrameRef::new(&shutter, w, h).unwrap()).unwrap();
    assert_eq!(report.clamped, 0);
    assert_eq!(report.pixels as usize, bad.iter().filter(|b| !**b).count());
    // The corrected shutter frame is the level on every pixel.
    let t = NucTables::new(w, h, &gain, &offset).unwrap();
    let mut out = vec![0u16; w * h];
    nuc_frame(&t, FrameRef::new(&shutter, w, h).unwrap(), FrameMut::new(&mut out, w, h).unwrap()).unwrap();
    assert!(out.iter().all(|&v| i32::from(v) == report.level), "flat at {}", report.level);
    // The offsets are the f64 definition's within the two roundings (the level's and the gain
    // product's): one count.
    let offs: Vec<f64> = before.iter().map(|&o| f64::from(o)).collect();
    let valid: Vec<bool> = bad.iter().map(|b| !b).collect();
    let r = reference::shutter_offsets(&shutter, &real(&gain), &offs, &valid);
    for (&c, &r) in offset.iter().zip(&r) {
        assert!((f64::from(c) - r).abs() <= 1.0, "{c} vs {r}");
    }
}

#[test]
fn bad_pixels_take_the_reference_median() {
    let mut rng = Rng::new(13);
    for (w, h, fraction) in [(64, 40, 0.02), (19, 23, 0.2), (130, 9, 0.005)] {
        let (gain, offset) = tables(w * h, &mut rng);
        let raw = raw_frame(w, h, 14, &mut rng);
        let (bad, bits) = bad_map(w, h, fraction, &mut rng);
        let stages = Correction {
            nuc: Some(NucTables::new(w, h, &gain, &offset).unwrap()),
            bad: Some(BadPixelMap::new(w, h, &bits).unwrap()),
        };
        let mut out = vec![0u16; w * h];
        correct_frame(
            &stages,
            None,
            FrameRef::new(&raw, w, h).unwrap(),
            FrameMut::new(&mut out, w, h).unwrap(),
        )
        .unwrap();
        // The reference replaces on the corrected frame (the core's NUC is checked above).
        let mut nuc = vec![0u16; w * h];
        let t = NucTables::new(w, h, &gain, &offset).unwrap();
        nuc_frame(&t, FrameRef::new(&raw, w, h).unwrap(), FrameMut::new(&mut nuc, w, h).unwrap()).unwrap();
        let nuc_f: Vec<f64> = nuc.iter().map(|&v| f64::from(v)).collect();
        let r = reference::replace_bad(&nuc_f, &bad, w, h);
        for (i, (&c, r)) in out.iter().zip(&r).enumerate() {
            assert_eq!(f64::from(c), round_half_up(r.unwrap()), "{w}x{h} pixel {i} bad {}", bad[i]);
        }
    }
}

#[test]
fn frame_strips_and_rows_give_the_same_bits() {
    let mut rng = Rng::new(17);
    let (w, h) = (200, 150);
    let (gain, offset) = tables(w * h, &mut rng);
    let raw = raw_frame(w, h, 14, &mut rng);
    let (_, bits) = bad_map(w, h, 0.01, &mut rng);
    let stages = Correction {
        nuc: Some(NucTables::new(w, h, &gain, &offset).unwrap()),
        bad: Some(BadPixelMap::new(w, h, &bits).unwrap()),
    };
    let raw_f = FrameRef::new(&raw, w, h).unwrap();
    let mut whole = vec![0u16; w * h];
    correct_frame(&stages, None, raw_f, FrameMut::new(&mut whole, w, h).unwrap()).unwrap();
    // Strips of 37 rows, each into its own buffer.
    let mut strips = Vec::new();
    for y0 in (0..h).step_by(37) {
        let rows = 37.min(h - y0);
        let mut s = vec![0u16; w * rows];
        correct_strip(&stages, raw_f, y0, FrameMut::new(&mut s, w, rows).unwrap()).unwrap();
        strips.extend(s);
    }
    assert_eq!(strips, whole);
    // Line by line: each row once the row below it is read out.
    let mut rows = vec![0u16; w * h];
    for (y, out) in rows.chunks_mut(w).enumerate() {
        let above = y.checked_sub(1).map(|a| raw_f.row(a));
        let below = (y + 1 < h).then(|| raw_f.row(y + 1));
        correct_row(&stages, h, y, above, raw_f.row(y), below, out).unwrap();
    }
    assert_eq!(rows, whole);
}

/// A scene with a gentle gradient, a warm square, noise and column offsets (σ 30 counts).
fn striped(w: usize, h: usize, rng: &mut Rng) -> Vec<u16> {
    let cols: Vec<f64> = (0..w).map(|_| rng.normal(0.0, 30.0)).collect();
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let warm = x > w / 3 && x < w / 2 && y > h / 3 && y < 2 * h / 3;
            let level = if warm { 9_000.0 } else { 4_000.0 + 3.0 * x as f64 };
            rng.normal(level + cols[x], 20.0).round() as u16
        })
        .collect()
}

fn column_sd(frame: &[u16], clean_cols: &dyn Fn(usize) -> f64, w: usize, h: usize) -> f64 {
    // The spread of the column means' deviation from the scene's.
    let dev: Vec<f64> = (0..w)
        .map(|x| (0..h).map(|y| f64::from(frame[y * w + x])).sum::<f64>() / h as f64 - clean_cols(x))
        .collect();
    let m = dev.iter().sum::<f64>() / w as f64;
    (dev.iter().map(|d| (d - m).powi(2)).sum::<f64>() / w as f64).sqrt()
}

#[test]
fn the_column_filter_removes_column_offsets_as_the_reference_does() {
    let mut rng = Rng::new(21);
    let (w, h) = (256, 192);
    let frame = striped(w, h, &mut rng);
    let p = ColumnParams { threshold: 150, radius: 16, smoothing: 0 };
    let mut out = frame.clone();
    let mut filter = ColumnFilter::new();
    column_filter_frame(&mut filter, FrameMut::new(&mut out, w, h).unwrap(), &p).unwrap();
    // Against the f64 definition: each column's Q4 rounding (1/32 count) adds up along the
    // profile, and the estimate keeps the difference between the profile's rounding at x and
    // its mean over the window: at most (2r + 1)/32 counts; the window mean's rounding 1/32,
    // the final rounding 1/2.
    let f: Vec<f64> = frame.iter().map(|&v| f64::from(v)).collect();
    let r = reference::column_estimate(&f, w, h, 150.0, 16);
    let bound = 0.5 + (2.0 * 16.0 + 2.0) / 32.0;
    for (x, &e) in r.iter().enumerate() {
        let got = f64::from(filter.correction(x));
        assert!((got - e).abs() <= bound, "column {x}: core {got}, reference {e}");
    }
    // The column offsets (30 counts spread) are mostly gone. What stays: the offsets' own mean
    // over the window (30/√33 ≈ 5 counts, a slow ripple, not stripes) and the noise summed
    // along the profile (28·√(16/(3·192)) ≈ 5 counts): about 7.
    let scene = |x: usize| {
        (0..h)
            .map(|y| {
                let warm = x > w / 3 && x < w / 2 && y > h / 3 && y < 2 * h / 3;
                if warm { 9_000.0 } else { 4_000.0 + 3.0 * x as f64 }
            })
            .sum::<f64>()
            / h as f64
    };
    let before = column_sd(&frame, &scene, w, h);
    let after = column_sd(&out, &scene, w, h);
    assert!(before > 25.0 && after < before / 3.0, "column spread {before:.1} → {after:.1}");
}

#[test]
fn column_filter_orders_agree() {
    let mut rng = Rng::new(23);
    let (w, h) = (128, 96);
    let a = striped(w, h, &mut rng);
    let b = striped(w, h, &mut rng);
    let p = ColumnParams { threshold: 100, radius: 8, smoothing: 2 };
    // Whole frames with smoothing: a then b.
    let mut filter = ColumnFilter::new();
    let mut wa = a.clone();
    column_filter_frame(&mut filter, FrameMut::new(&mut wa, w, h).unwrap(), &p).unwrap();
    let mut wb = b.clone();
    column_filter_frame(&mut filter, FrameMut::new(&mut wb, w, h).unwrap(), &p).unwrap();
    // The same with rows accumulated in strips and applied after the update.
    let mut s = ColumnFilter::new();
    for frame in [&a, &b] {
        for row in frame.chunks(w) {
            s.accumulate(row, &p).unwrap();
        }
        s.update(&p).unwrap();
    }
    let mut sb = vec![0u16; w * h];
    for (i, o) in b.chunks(w).zip(sb.chunks_mut(w)) {
        s.apply(i, o).unwrap();
    }
    assert_eq!(sb, wb);
    // One pass: frame b mapped with the estimate built at the end of frame a.
    let mut one = ColumnFilter::new();
    for row in a.chunks(w) {
        one.accumulate(row, &p).unwrap();
    }
    one.update(&p).unwrap();
    let mut ob = vec![0u16; w * h];
    for (i, o) in b.chunks(w).zip(ob.chunks_mut(w)) {
        one.apply(i, o).unwrap();
        one.accumulate(i, &p).unwrap();
    }
    let mut first = ColumnFilter::new();
    let mut fa = a.clone();
    column_filter_frame(&mut first, FrameMut::new(&mut fa, w, h).unwrap(), &p).unwrap();
    let expect: Vec<u16> = b
        .chunks(w)
        .flat_map(|row| {
            row.iter().enumerate().map(|(x, &v)| (i32::from(v) - first.correction(x)).clamp(0, 65_535) as u16)
        })
        .collect();
    assert_eq!(ob, expect);
}

#[test]
fn bad_tables_and_maps_are_refused_with_nothing_written() {
    let (w, h) = (16, 8);
    let gain = vec![GAIN_ONE; w * h];
    let offset = vec![0i16; w * h];
    assert!(NucTables::new(w, h, &gain[1..], &offset).is_err());
    assert!(NucTables::new(w, h, &gain, &offset[1..]).is_err());
    assert_eq!(NucTables::new(0, h, &[], &[]).unwrap_err(), Error::ZeroDimension);
    // Map: wrong length; bits past the width; a bad pixel with nothing valid around or in its
    // row (three whole rows dead).
    assert!(BadPixelMap::new(w, h, &vec![0u8; bad_map_bytes(w, h) + 1]).is_err());
    let mut past = vec![0u8; bad_map_bytes(10, 2)];
    past[1] = 0b100;
    assert!(BadPixelMap::new(10, 2, &past).is_err());
    let mut rows = vec![false; w * h];
    rows[2 * w..5 * w].iter_mut().for_each(|b| *b = true);
    assert!(BadPixelMap::new(w, h, &pack(&rows, w, h)).is_err());
    // Two dead rows are fine (each has the rows beside it).
    let mut two = vec![false; w * h];
    two[2 * w..4 * w].iter_mut().for_each(|b| *b = true);
    assert_eq!(BadPixelMap::new(w, h, &pack(&two, w, h)).unwrap().count(), 2 * w as u32);
    // Tables of another size than the frame: Err, the output untouched.
    let t = NucTables::new(w, h, &gain, &offset).unwrap();
    let stages = Correction { nuc: Some(t), bad: None };
    let raw = vec![100u16; (w + 1) * h];
    let mut out = vec![7u16; (w + 1) * h];
    let e = correct_frame(
        &stages,
        None,
        FrameRef::new(&raw, w + 1, h).unwrap(),
        FrameMut::new(&mut out, w + 1, h).unwrap(),
    );
    assert!(matches!(e, Err(Error::SizeMismatch { .. })));
    assert!(out.iter().all(|&v| v == 7));
    // Column parameters out of range: Err, untouched.
    let raw = vec![100u16; w * h];
    let mut out = vec![7u16; w * h];
    for p in [
        ColumnParams { threshold: 0, radius: 4, smoothing: 0 },
        ColumnParams { threshold: 40_000, radius: 4, smoothing: 0 },
        ColumnParams { threshold: 10, radius: 0, smoothing: 0 },
        ColumnParams { threshold: 10, radius: 4, smoothing: 9 },
    ] {
        let mut f = ColumnFilter::new();
        let e = correct_frame(
            &Correction::default(),
            Some((&mut f, &p)),
            FrameRef::new(&raw, w, h).unwrap(),
            FrameMut::new(&mut out, w, h).unwrap(),
        );
        assert!(matches!(e, Err(Error::InvalidParameter { .. })), "{p:?}");
        assert!(out.iter().all(|&v| v == 7));
    }
    // A shutter frame with every pixel bad cannot level anything.
    let all_bad = vec![0xffu8; bad_map_bytes(8, 1)];
    assert!(BadPixelMap::new(8, 1, &all_bad).is_err());
    let mut off = vec![5i16; w * h];
    let short = vec![0u16; w * h - 1];
    assert!(shutter_update(&gain[1..], &mut off, None, FrameRef::new(&raw, w, h).unwrap()).is_err());
    assert!(shutter_update(&short, &mut off, None, FrameRef::new(&raw, w, h).unwrap()).is_err());
    assert!(off.iter().all(|&o| o == 5));
}

#[test]
fn the_documented_memory_holds() {
    use fusion_nostd::thermal::nuc_table_bytes;
    // Tables 4 bytes a pixel, the map a bit, the column state 28 KiB (module docs).
    assert_eq!(nuc_table_bytes(512, 512), 1 << 20);
    assert_eq!(nuc_table_bytes(640, 512), 1_310_720);
    assert_eq!((bad_map_bytes(512, 512), bad_map_bytes(640, 512)), (32 * 1024, 40 * 1024));
    let column = std::mem::size_of::<ColumnFilter>();
    assert!(column > 28 * 1024 && column < 29 * 1024, "{column}");
}
