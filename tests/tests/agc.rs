//! The thermal AGC (`fusion_nostd::agc`): the integer core against the f64 reference written
//! from the definition (sorted-sample percentiles, one division per bin), a hand-computed tiny
//! case, strips and the previous-frame order against the whole frame, smoothing over a sequence,
//! and bad input refused with nothing written.

use fusion_io::Gray;
use fusion_nostd::agc::{AGC_BINS, Agc, AgcMode, AgcParams, agc_frame};
use fusion_nostd::{Error, FrameMut, FrameRef};
use fusion_reference::agc::AgcReference;

/// The host's seeded generator, with the draws these tests need.
struct Rng(render_host::noise::SplitMix64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0.next_u64()
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    /// Roughly normal: the sum of four uniforms.
    fn normal(&mut self, mean: f64, sigma: f64) -> f64 {
        let s: f64 = (0..4).map(|_| (self.next() >> 11) as f64 / (1u64 << 53) as f64).sum();
        mean + sigma * (s - 2.0) * 3f64.sqrt()
    }
}

/// A thermal-like frame: cold background with 1/f-free noise, a warm target block with a hot
/// spot, in a 14-bit (`bits` 14) or 16-bit range.
fn thermal_frame(w: usize, h: usize, bits: u32, rng: &mut Rng) -> Gray<u16> {
    let full = f64::from((1u32 << bits) - 1);
    let (cold, warm, hot) = (0.18 * full, 0.45 * full, 0.8 * full);
    let (x0, y0) = (rng.below(w as u64 / 2 + 1) as usize, rng.below(h as u64 / 2 + 1) as usize);
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let inside = x >= x0 && x < x0 + w / 3 && y >= y0 && y < y0 + h / 3;
            let level = if inside && x < x0 + 3 && y < y0 + 3 {
                hot
            } else if inside {
                warm + 0.05 * full * (x - x0) as f64 / (w / 3) as f64
            } else {
                cold
            };
            rng.normal(level, 0.004 * full).round().clamp(0.0, full) as u16
        })
        .collect();
    Gray { width: w, height: h, data }
}

fn core_frame(agc: &mut Agc, img: &Gray<u16>, p: &AgcParams) -> Gray<u8> {
    let mut out = Gray::<u8>::new(img.width, img.height);
    agc_frame(agc, img.view().unwrap(), out.view_mut().unwrap(), p).unwrap();
    out
}

fn params(mode: AgcMode, out_low: u8, out_high: u8, smoothing: u8) -> AgcParams {
    AgcParams { mode, out_low, out_high, smoothing }
}

#[test]
fn core_equals_the_f64_reference() {
    let mut rng = Rng(render_host::noise::SplitMix64::new(7));
    let modes = [
        AgcMode::Plateau { limit: 1 },
        AgcMode::Plateau { limit: 40 },
        AgcMode::Plateau { limit: AgcParams::plateau_for(97 * 61) },
        AgcMode::Plateau { limit: u32::MAX },
        AgcMode::Linear { low: 50, high: 9_950 },
        AgcMode::Linear { low: 0, high: 10_000 },
        AgcMode::Linear { low: 2_500, high: 2_501 },
    ];
    let mut checked = 0;
    for bits in [8, 14, 16] {
        for (w, h) in [(97, 61), (1, 1), (256, 3), (13, 200)] {
            let img = thermal_frame(w, h, bits, &mut rng);
            for mode in modes {
                for (lo, hi) in [(0, 255), (16, 235), (0, 1)] {
                    let p = params(mode, lo, hi, 0);
                    let core = core_frame(&mut Agc::new(), &img, &p);
                    let reference = AgcReference::default().frame(&img, &p);
                    assert_eq!(core.data, reference.data, "{bits}-bit {w}x{h} {mode:?} {lo}..{hi}");
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 3 * 4 * 7 * 3);
}

#[test]
fn hand_computed_tiny_frames() {
    // Bins 0, 1, 2, 3 (counts 0, 4, 8, 12 and one more in bin 3): plateau without a real
    // limit maps the clipped cumulative counts 0, 1, 2, 4 of den 4 to 0, 64, 128, 255.
    let img = Gray { width: 5, height: 1, data: vec![0u16, 4, 8, 12, 15] };
    let p = params(AgcMode::Plateau { limit: 1000 }, 0, 255, 0);
    assert_eq!(core_frame(&mut Agc::new(), &img, &p).data, vec![0, 64, 128, 255, 255]);
    // A plateau of 1 counts bin 3 once: cumulative 0, 1, 2, 3 of den 3 → 0, 85, 170, 255.
    let p = params(AgcMode::Plateau { limit: 1 }, 0, 255, 0);
    assert_eq!(core_frame(&mut Agc::new(), &img, &p).data, vec![0, 85, 170, 255, 255]);
    // Linear between the 1st and the 5th sample's bins (0 and 3): b·255/3.
    let p = params(AgcMode::Linear { low: 0, high: 10_000 }, 0, 255, 0);
    assert_eq!(core_frame(&mut Agc::new(), &img, &p).data, vec![0, 85, 170, 255, 255]);
    // One bin only: mid-range, below it out_low, above it out_high (checked on the table).
    let flat = Gray { width: 3, height: 1, data: vec![400u16; 3] };
    let p = params(AgcMode::Plateau { limit: 7 }, 10, 20, 0);
    let mut agc = Agc::new();
    assert_eq!(core_frame(&mut agc, &flat, &p).data, vec![15; 3]);
    assert_eq!((agc.table()[99], agc.table()[100], agc.table()[101]), (10, 15, 20));
}

#[test]
fn tables_are_monotone_and_span_the_output_range() {
    let mut rng = Rng(render_host::noise::SplitMix64::new(11));
    let img = thermal_frame(128, 96, 16, &mut rng);
    for mode in [AgcMode::Plateau { limit: 192 }, AgcMode::Linear { low: 100, high: 9_900 }] {
        let mut agc = Agc::new();
        let out = core_frame(&mut agc, &img, &params(mode, 3, 250, 0));
        assert!(agc.table().windows(2).all(|w| w[0] <= w[1]), "{mode:?}: monotone");
        assert_eq!(out.data.iter().min(), Some(&3), "{mode:?}");
        assert_eq!(out.data.iter().max(), Some(&250), "{mode:?}");
    }
}

#[test]
fn strips_and_the_previous_frame_order_give_the_whole_frame_bits() {
    let mut rng = Rng(render_host::noise::SplitMix64::new(3));
    let (a, b) = (thermal_frame(200, 150, 14, &mut rng), thermal_frame(200, 150, 14, &mut rng));
    let p = AgcParams::plateau(200 * 150);
    let whole_a = core_frame(&mut Agc::new(), &a, &p);
    // First pass in strips of 37 rows, then the mapping applied in strips.
    let mut agc = Agc::new();
    for strip in a.data.chunks(200 * 37) {
        agc.accumulate(strip).unwrap();
    }
    agc.update(&p).unwrap();
    let mut strips = vec![0u8; a.data.len()];
    for (i, o) in a.data.chunks(200 * 37).zip(strips.chunks_mut(200 * 37)) {
        agc.apply(i, o).unwrap();
    }
    assert_eq!(strips, whole_a.data);
    // One pass over frame b with a's mapping, accumulating b as it goes; then b's own mapping.
    let mut one_pass = vec![0u8; b.data.len()];
    for (i, o) in b.data.chunks(200).zip(one_pass.chunks_mut(200)) {
        agc.apply(i, o).unwrap();
        agc.accumulate(i).unwrap();
    }
    let table_a = *agc.table();
    assert!(b.data.iter().zip(&one_pass).all(|(&x, &y)| table_a[usize::from(x >> 2)] == y));
    agc.update(&p).unwrap();
    assert_eq!(agc.table(), Agc::new_table(&b, &p).as_slice());
}

trait NewTable {
    fn new_table(img: &Gray<u16>, p: &AgcParams) -> Vec<u8>;
}
impl NewTable for Agc {
    fn new_table(img: &Gray<u16>, p: &AgcParams) -> Vec<u8> {
        let mut agc = Agc::new();
        core_frame(&mut agc, img, p);
        agc.table().to_vec()
    }
}

#[test]
fn smoothing_over_a_sequence_matches_the_reference_and_damps_the_level() {
    // The same scene each frame except a hot block whose size alternates: a plain
    // equalisation moves the level of everything else with it (flicker).
    let mut rng = Rng(render_host::noise::SplitMix64::new(5));
    let base = thermal_frame(120, 90, 16, &mut rng);
    let frames: Vec<Gray<u16>> = (0..40)
        .map(|i| {
            let mut f = base.clone();
            for v in &mut f.data {
                *v = v.saturating_add(rng.below(64) as u16);
            }
            let side = if i % 2 == 0 { 10 } else { 40 };
            for y in 0..side {
                for x in 0..side {
                    f.data[y * 120 + x] = 60_000;
                }
            }
            f
        })
        .collect();
    let mean_step = |k: u8| {
        let p = AgcParams { smoothing: k, ..AgcParams::plateau(120 * 90) };
        let (mut agc, mut reference) = (Agc::new(), AgcReference::default());
        let mut means = Vec::new();
        for f in &frames {
            let core = core_frame(&mut agc, f, &p);
            assert_eq!(core.data, reference.frame(f, &p).data, "smoothing {k}");
            // The level of what did not change: every pixel outside the hot block's corner.
            let kept: Vec<f64> = (0..core.data.len())
                .filter(|i| i % 120 >= 40 || i / 120 >= 40)
                .map(|i| f64::from(core.data[i]))
                .collect();
            means.push(kept.iter().sum::<f64>() / kept.len() as f64);
        }
        // After the smoothing's settling (the first 16 frames).
        let steps: Vec<f64> = means[16..].windows(2).map(|w| (w[1] - w[0]).abs()).collect();
        steps.iter().sum::<f64>() / steps.len() as f64
    };
    let (plain, smoothed) = (mean_step(0), mean_step(3));
    assert!(smoothed < 0.5 * plain, "mean level step {smoothed:.2} with smoothing, {plain:.2} without");
}

#[test]
fn smoothing_reaches_a_still_scene_exactly_from_above_and_below() {
    // A scene that changes once and then holds still: the smoothed mapping must end on the
    // still scene's own table, whichever way its levels moved (a floor-only step would stop
    // short on the rising bins).
    let mut rng = Rng(render_host::noise::SplitMix64::new(9));
    let (a, b) = (thermal_frame(40, 30, 16, &mut rng), thermal_frame(40, 30, 14, &mut rng));
    for (first, still) in [(&a, &b), (&b, &a)] {
        let p = AgcParams { smoothing: 3, ..AgcParams::linear() };
        let (mut agc, mut reference) = (Agc::new(), AgcReference::default());
        core_frame(&mut agc, first, &p);
        reference.frame(first, &p);
        for _ in 0..120 {
            let core = core_frame(&mut agc, still, &p);
            assert_eq!(core.data, reference.frame(still, &p).data);
        }
        assert_eq!(agc.table().as_slice(), Agc::new_table(still, &p).as_slice());
    }
}

#[test]
fn bad_input_is_refused_and_nothing_is_written() {
    let img = Gray { width: 4, height: 2, data: vec![1000u16; 8] };
    let mut out = vec![9u8; 8];
    let bad = [
        (params(AgcMode::Plateau { limit: 0 }, 0, 255, 0), "agc plateau limit"),
        (params(AgcMode::Linear { low: 10, high: 10 }, 0, 255, 0), "agc percentiles"),
        (params(AgcMode::Linear { low: 0, high: 10_001 }, 0, 255, 0), "agc percentiles"),
        (params(AgcMode::Plateau { limit: 5 }, 200, 200, 0), "agc output range"),
        (params(AgcMode::Plateau { limit: 5 }, 0, 255, 9), "agc smoothing"),
    ];
    for (p, name) in bad {
        let r = agc_frame(
            &mut Agc::new(),
            FrameRef::new(&img.data, 4, 2).unwrap(),
            FrameMut::new(&mut out, 4, 2).unwrap(),
            &p,
        );
        assert_eq!(r, Err(Error::InvalidParameter { name }));
        assert_eq!(out, vec![9; 8]);
    }
    let p = AgcParams::plateau(8);
    let r = agc_frame(
        &mut Agc::new(),
        FrameRef::new(&img.data, 4, 2).unwrap(),
        FrameMut::new(&mut out, 2, 4).unwrap(),
        &p,
    );
    assert_eq!(r, Err(Error::SizeMismatch { expected: (4, 2), got: (2, 4) }));
    assert_eq!(out, vec![9; 8]);
    let mut agc = Agc::new();
    assert_eq!(agc.apply(&img.data, &mut out), Err(Error::InvalidParameter { name: "agc mapping" }));
    assert_eq!(agc.update(&p), Err(Error::InvalidParameter { name: "agc histogram (no pixels)" }));
    agc.accumulate(&img.data).unwrap();
    agc.update(&p).unwrap();
    assert_eq!(agc.apply(&img.data, &mut out[..7]), Err(Error::BufferTooSmall { needed: 8, got: 7 }));
    assert_eq!(out, vec![9; 8]);
    assert_eq!(AGC_BINS, 1 << 14);
}
