//! Shared helpers for the cross-crate integration tests in `tests/tests/`.

use fusion_io::Gray;
use render_host::noise::SplitMix64;

/// Random test images from the host's one seeded generator
/// ([`render_host::noise::SplitMix64`]).
#[derive(Debug, Clone)]
pub struct TestRng(SplitMix64);

impl TestRng {
    /// A generator from a seed.
    pub fn new(seed: u64) -> Self {
        Self(SplitMix64::new(seed))
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// A uniform random u8 image.
    pub fn image_u8(&mut self, width: usize, height: usize) -> Gray<u8> {
        Gray { width, height, data: (0..width * height).map(|_| self.next_u64() as u8).collect() }
    }

    /// A uniform random u16 image.
    pub fn image_u16(&mut self, width: usize, height: usize) -> Gray<u16> {
        Gray { width, height, data: (0..width * height).map(|_| self.next_u64() as u16).collect() }
    }
}

/// Where two images differ: `(count, first differing (x, y, a, b))`.
pub fn diff<T: PartialEq + Copy>(a: &Gray<T>, b: &Gray<T>) -> (usize, Option<(usize, usize, T, T)>) {
    assert_eq!((a.width, a.height), (b.width, b.height), "image sizes differ");
    let mut count = 0;
    let mut first = None;
    for (i, (p, q)) in a.data.iter().zip(&b.data).enumerate() {
        if p != q {
            count += 1;
            first.get_or_insert((i % a.width, i / a.width, *p, *q));
        }
    }
    (count, first)
}

/// Asserts two images are identical, printing the first differing coordinate.
#[track_caller]
pub fn assert_same<T: PartialEq + Copy + std::fmt::Debug>(a: &Gray<T>, b: &Gray<T>, what: &str) {
    let (count, first) = diff(a, b);
    assert_eq!(count, 0, "{what}: {count} pixels differ, first at (x, y, got, want) = {first:?}");
}

/// Mirrors an image left-right.
pub fn flip_lr<T: Copy + Default>(g: &Gray<T>) -> Gray<T> {
    let mut out = Gray::new(g.width, g.height);
    for y in 0..g.height {
        for x in 0..g.width {
            out.data[y * g.width + x] = g.at(g.width - 1 - x, y);
        }
    }
    out
}

/// Mirrors an image top-bottom.
pub fn flip_ud<T: Copy + Default>(g: &Gray<T>) -> Gray<T> {
    let mut out = Gray::new(g.width, g.height);
    for y in 0..g.height {
        for x in 0..g.width {
            out.data[y * g.width + x] = g.at(x, g.height - 1 - y);
        }
    }
    out
}

/// Transposes an image.
pub fn transpose<T: Copy + Default>(g: &Gray<T>) -> Gray<T> {
    let mut out = Gray::new(g.height, g.width);
    for y in 0..g.height {
        for x in 0..g.width {
            out.data[x * g.height + y] = g.at(x, y);
        }
    }
    out
}

/// A smooth synthetic scene with a target, texture and noise (not a VIFB image).
pub fn scene(w: usize, h: usize, seed: u64) -> Gray<u8> {
    let mut rng = TestRng::new(seed);
    let data = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64, (i / w) as f64);
            let (dx, dy) = (x - 0.45 * w as f64, y - 0.5 * h as f64);
            let r2 = (dx * dx + dy * dy) / ((w * h) as f64 * 0.03 + 1.0);
            let target = if r2 < 1.0 { 150.0 + 40.0 * (x * 0.7).sin() } else { 10.0 };
            let noise = (rng.next_u64() % 13) as f64 - 6.0;
            (target + 20.0 * (y * 0.05 + seed as f64).cos() + noise).clamp(0.0, 255.0) as u8
        })
        .collect();
    Gray { width: w, height: h, data }
}
