//! Exact sum of the `k` largest step-9 keys from a histogram of pixel classes.
//!
//! The key of a pixel, `VIS·2²⁴ + max(R·2²⁴ + (IR − VIS)·r_H, 0)` (Q24, [`KEY_BITS`]), depends
//! on the pixel's `(v, R, d = IR − VIS)` only through its *class*:
//! * where `R·2²⁴ + d·r_H > 0` — equivalently `R ≥ r_min(d)`, tabulated per `d` — the key is
//!   `s·2²⁴ + d·r_H` with `s = v + R`: one class per `(s, d)`, 511 × 511 of them;
//! * elsewhere the key is `v·2²⁴`: one class per `v`, 256 more.
//!
//! So IFEVIP counts classes while it computes `R` (one increment per pixel, [`Classes::class`])
//! and never stores a per-pixel key; [`top_k_sum`] then works on the [`CLASSES`] counts: it
//! lists the occupied classes, histograms their keys (weighted by the counts) in 1024 bins over
//! the keys' range, adds up the classes above the bin holding the `k`-th largest key and keeps
//! the ones inside it, and repeats on those until the bin holds one key value `T`; the sum is
//! `Σ above + (k − #above)·T`. Exact for any key distribution, no sort; each round shrinks the
//! key range 1024-fold, so there are at most seven rounds (64-bit keys, 10 bits a round) over at most [`CLASSES`] entries.
//!
//! The keys saturate at `i64::MAX` exactly where the per-pixel formula with saturating
//! arithmetic does (only for `r_H` beyond any entropy ratio of a real frame).

/// Fractional bits of the keys.
pub const KEY_BITS: u32 = 24;

/// Values of `s = v + R` and of `d = IR − VIS` (each `0..=510` after the offset of `d`).
const SPAN: usize = 511;

/// Classes with a key `s·2²⁴ + d·r_H`: index `s·511 + (d + 255)`.
const PAIRS: usize = SPAN * SPAN;

/// Number of classes: the `(s, d)` pairs, then one per `v` (key `v·2²⁴`).
pub const CLASSES: usize = PAIRS + 256;

/// Bins of each selection histogram.
const BINS: usize = 1024;

/// The class map of one frame (its entropy ratio `r_H` in Q24).
#[derive(Debug, Clone)]
pub struct Classes {
    /// `r_min(d)` at index `d + 255`: the least `R` (0..=256) with `R·2²⁴ + d·r_H > 0`.
    r_min: [u16; SPAN],
    /// `d·r_H` (Q24, saturating) at index `d + 255`.
    d_term: [i64; SPAN],
}

impl Classes {
    /// The class map for the ratio `r_H = ratio_q24 / 2²⁴` (`ratio_q24 ≥ 0`).
    pub fn new(ratio_q24: i64) -> Self {
        let ratio_q24 = ratio_q24.max(0);
        let mut r_min = [0u16; SPAN];
        let mut d_term = [0i64; SPAN];
        for (di, t) in d_term.iter_mut().enumerate() {
            *t = (di as i64 - 255).saturating_mul(ratio_q24);
        }
        for (di, r) in r_min.iter_mut().enumerate() {
            let d = di as i64 - 255;
            // Least R with R·2²⁴ > −d·r_H: 0 when d·r_H > 0, else ⌊−d·r_H / 2²⁴⌋ + 1.
            let deficit = d.saturating_mul(ratio_q24).saturating_neg();
            *r = if deficit < 0 { 0 } else { ((deficit >> KEY_BITS) + 1).min(256) as u16 };
        }
        Self { r_min, d_term }
    }

    /// The class of a pixel with visible value `v`, IR value `t` and feature `r` (`0..=255`).
    #[inline(always)]
    pub fn class(&self, v: u8, t: u8, r: i32) -> usize {
        let di = usize::from(t) + 255 - usize::from(v);
        let least = self.r_min.get(di).copied().unwrap_or(u16::MAX);
        // Branch-free select (the condition follows the image, a branch would mispredict).
        let pair = (usize::from(v) + r as usize) * SPAN + di;
        let single = PAIRS + usize::from(v);
        let mask = usize::from(r >= i32::from(least)).wrapping_neg();
        (pair & mask) | (single & !mask)
    }

    /// The key (Q24) of a pixel with visible value `v`, IR value `t` and feature `r`
    /// (`0..=255`): `self.key(self.class(v, t, r))` without the division by 511.
    #[inline(always)]
    pub fn key_of(&self, v: u8, t: u8, r: i32) -> i64 {
        let di = usize::from(t) + 255 - usize::from(v);
        let least = self.r_min.get(di).copied().unwrap_or(u16::MAX);
        if r >= i32::from(least) {
            (i64::from(i32::from(v) + r) << KEY_BITS)
                .saturating_add(self.d_term.get(di).copied().unwrap_or(0))
        } else {
            i64::from(v) << KEY_BITS
        }
    }

    /// The key (Q24) of every pixel of class `c`.
    #[inline]
    pub fn key(&self, c: usize) -> i64 {
        if c >= PAIRS {
            ((c - PAIRS) as i64) << KEY_BITS
        } else {
            let (s, di) = (c / SPAN, c % SPAN);
            ((s as i64) << KEY_BITS).saturating_add(self.d_term.get(di).copied().unwrap_or(0))
        }
    }
}

/// The bin (from the top) where the cumulative count reaches `need`, and the count above it.
fn select(hist: &[u64; BINS], need: u64) -> (usize, u64) {
    let mut above = 0u64;
    for (b, &c) in hist.iter().enumerate().rev() {
        if above + c >= need {
            return (b, above);
        }
        above += c;
    }
    (0, above)
}

/// Sum (Q24) of the `k` largest keys of the pixels counted in `counts` (one count per class,
/// [`CLASSES`] of them; see [`Classes`]). `work` (at least as long as the number of occupied
/// classes, at most [`CLASSES`]) holds the candidate classes. `k = 0` gives 0; `k` above the
/// number of pixels sums all keys.
pub fn top_k_sum(counts: &[i32], classes: &Classes, k: u64, work: &mut [i32]) -> i128 {
    // Occupied classes into `work`, with the key range and the pixel count.
    let mut n = 0usize;
    let mut total = 0u64;
    let (mut lo, mut hi) = (i64::MAX, i64::MIN);
    for (c, &count) in counts.iter().enumerate().take(CLASSES) {
        if count > 0 {
            let Some(slot) = work.get_mut(n) else { break };
            *slot = c as i32;
            n += 1;
            total += count as u64;
            let key = classes.key(c);
            lo = lo.min(key);
            hi = hi.max(key);
        }
    }
    let mut need = k.min(total);
    let mut sum: i128 = 0;
    let count_of = |c: usize| counts.get(c).map_or(0, |&x| x.max(0) as u64);
    while need > 0 && n > 0 {
        if hi <= lo {
            return sum + i128::from(need) * i128::from(lo);
        }
        // 1024 bins of width 2^shift over [lo, hi].
        let span = (hi - lo) as u64;
        let shift = (64 - span.leading_zeros()).saturating_sub(BINS.trailing_zeros());
        let bin = |key: i64| ((key - lo) as u64 >> shift) as usize;
        let mut hist = [0u64; BINS];
        for &c in work.iter().take(n) {
            let c = c as usize;
            if let Some(h) = hist.get_mut(bin(classes.key(c))) {
                *h += count_of(c);
            }
        }
        let (t, above) = select(&hist, need);
        need -= above;
        // Add the classes above bin t, keep the ones in it (compacted to the front).
        let (mut kept, mut new_lo, mut new_hi) = (0usize, i64::MAX, i64::MIN);
        for i in 0..n {
            let Some(&c) = work.get(i) else { break };
            let key = classes.key(c as usize);
            let b = bin(key);
            if b > t {
                sum += i128::from(count_of(c as usize)) * i128::from(key);
            } else if b == t {
                if let Some(slot) = work.get_mut(kept) {
                    *slot = c;
                }
                kept += 1;
                new_lo = new_lo.min(key);
                new_hi = new_hi.max(key);
            }
        }
        (n, lo, hi) = (kept, new_lo, new_hi);
    }
    sum
}

/// Which pixels have a key above a threshold `T`, in 32-bit integers: a pixel of pair class
/// `(s, d)` has key `s·2²⁴ + d·r_H > T` exactly when `s > ⌊(T − d·r_H) / 2²⁴⌋` (s is an integer),
/// one of class `v` when `v > ⌊T / 2²⁴⌋`. The strip form forms the 64-bit key only for the
/// pixels that pass, and rebuilds the gate when [`TopK`] raises its threshold. It never turns
/// away a key above `T`; it lets through keys saturated at `i64::MAX` (their unsaturated value
/// is above), which [`TopK::push`] then weighs itself.
#[derive(Debug, Clone)]
pub struct Gate {
    /// The least-exceeded `s` per `d + 255`, clamped to `−1..=511`.
    s_limit: [i16; SPAN],
    v_limit: i16,
}

impl Gate {
    /// The gate for threshold `threshold`.
    pub fn new(classes: &Classes, threshold: i64) -> Self {
        let clamp = |l: i64, hi: i64| l.clamp(-1, hi) as i16;
        let mut s_limit = [0i16; SPAN];
        for (lim, &t) in s_limit.iter_mut().zip(&classes.d_term) {
            *lim = clamp(threshold.saturating_sub(t) >> KEY_BITS, 511);
        }
        Self { s_limit, v_limit: clamp(threshold >> KEY_BITS, 256) }
    }

    /// Whether the pixel `(v, t, r)` has a key above the threshold.
    #[inline(always)]
    pub fn passes(&self, classes: &Classes, v: u8, t: u8, r: i32) -> bool {
        let di = usize::from(t) + 255 - usize::from(v);
        let least = classes.r_min.get(di).copied().unwrap_or(u16::MAX);
        if r >= i32::from(least) {
            i32::from(v) + r > i32::from(self.s_limit.get(di).copied().unwrap_or(i16::MAX))
        } else {
            i16::from(v) > self.v_limit
        }
    }
}

/// Key `i` of a buffer of keys stored as `(low, high)` word pairs.
#[inline(always)]
fn key_at(words: &[i32], i: usize) -> Option<i64> {
    let lo = *words.get(2 * i)?;
    let hi = *words.get(2 * i + 1)?;
    Some((i64::from(hi) << 32) | i64::from(lo as u32))
}

/// Stores key `i`.
#[inline(always)]
fn set_key(words: &mut [i32], i: usize, key: i64) {
    if let Some([lo, hi]) = words.get_mut(2 * i..2 * i + 2) {
        *lo = key as i32;
        *hi = (key >> 32) as i32;
    }
}

/// The `k`-th largest (`1 ≤ k ≤ n`) of the first `n` keys in `words`: the histogram rounds of
/// [`top_k_sum`] without moving anything (each round scans all keys, at most seven rounds).
fn kth_key(words: &[i32], n: usize, k: usize) -> i64 {
    let keys = || (0..n).filter_map(|i| key_at(words, i));
    let (mut lo, mut hi) = keys().fold((i64::MAX, i64::MIN), |(lo, hi), key| (lo.min(key), hi.max(key)));
    let mut need = k as u64;
    while hi > lo {
        let span = (hi - lo) as u64;
        let shift = (64 - span.leading_zeros()).saturating_sub(BINS.trailing_zeros());
        let bin = |key: i64| ((key - lo) as u64 >> shift) as usize;
        let mut hist = [0u64; BINS];
        for key in keys() {
            if (lo..=hi).contains(&key)
                && let Some(h) = hist.get_mut(bin(key))
            {
                *h += 1;
            }
        }
        let (t, above) = select(&hist, need);
        need -= above;
        let (mut new_lo, mut new_hi) = (i64::MAX, i64::MIN);
        for key in keys() {
            if (lo..=hi).contains(&key) && bin(key) == t {
                new_lo = new_lo.min(key);
                new_hi = new_hi.max(key);
            }
        }
        (lo, hi) = (new_lo, new_hi);
    }
    lo
}

/// The `k` largest keys of a stream of pixels, in a caller buffer (two words per key): the strip
/// form of steps 9–10, which cannot hold the [`CLASSES`] counts. A pixel is kept while its key
/// exceeds the threshold; when the buffer fills, it is cut to the `k` largest (those above the
/// `k`-th largest key `T`, then copies of `T`) and `T` becomes the threshold. Equal keys are
/// interchangeable, so [`TopK::sum`] is the [`top_k_sum`] of all pushed pixels, exactly. A
/// buffer of `c > k` keys cuts at most once per `c − k` kept pixels.
#[derive(Debug)]
pub struct TopK<'w> {
    words: &'w mut [i32],
    len: usize,
    k: usize,
    /// Keys at or below it are not kept: −1 at first (every key is ≥ 0), `i64::MAX` for k = 0.
    threshold: i64,
}

impl<'w> TopK<'w> {
    /// Keeps the `k` largest keys in `buf` (two words per key), which must hold more than `k`.
    pub fn new(buf: &'w mut [i32], k: usize) -> Result<Self, crate::Error> {
        if buf.len() / 2 <= k {
            let needed = k.saturating_add(1).saturating_mul(2);
            return Err(crate::Error::ScratchTooSmall { needed, capacity: buf.len() });
        }
        Ok(Self { words: buf, len: 0, k, threshold: if k == 0 { i64::MAX } else { -1 } })
    }

    /// Words per key in the buffer.
    pub const WORDS_PER_KEY: usize = 2;

    /// Keys at or below this are not kept.
    pub fn threshold(&self) -> i64 {
        self.threshold
    }

    /// Adds a pixel's key.
    #[inline(always)]
    pub fn push(&mut self, key: i64) {
        if key <= self.threshold {
            return;
        }
        if self.len == self.words.len() / 2 {
            self.cut();
        }
        set_key(self.words, self.len, key);
        self.len += 1;
    }

    /// Cuts the keys to the `k` largest.
    fn cut(&mut self) {
        if self.len <= self.k {
            return;
        }
        let t = kth_key(self.words, self.len, self.k);
        let mut kept = 0usize;
        for i in 0..self.len {
            let Some(key) = key_at(self.words, i) else { break };
            if key > t {
                set_key(self.words, kept, key);
                kept += 1;
            }
        }
        for i in kept..self.k {
            set_key(self.words, i, t);
        }
        self.len = self.k.max(kept);
        self.threshold = t;
    }

    /// Sum (Q24) of the `k` largest keys pushed (all of them when fewer were pushed).
    pub fn sum(&self) -> i128 {
        let need = self.k.min(self.len);
        if need == 0 {
            return 0;
        }
        let t = kth_key(self.words, self.len, need);
        let (mut sum, mut above) = (0i128, 0usize);
        for key in (0..self.len).filter_map(|i| key_at(self.words, i)) {
            if key > t {
                sum += i128::from(key);
                above += 1;
            }
        }
        sum + (need - above) as i128 * i128::from(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    extern crate std;
    use std::vec::Vec;

    /// The published per-pixel key with saturating arithmetic.
    fn pixel_key(v: u8, t: u8, r: i32, ratio_q24: i64) -> i64 {
        let feat = (i64::from(r) << KEY_BITS)
            .saturating_add((i64::from(t) - i64::from(v)).saturating_mul(ratio_q24));
        (i64::from(v) << KEY_BITS).saturating_add(feat.max(0))
    }

    #[test]
    fn class_keys_equal_pixel_keys() {
        for ratio in [0i64, 1, 1 << 23, (1 << 24) + 12345, 3 << 25, i64::from(i32::MAX), 1 << 50, i64::MAX] {
            let classes = Classes::new(ratio);
            for t in (0..=255u8).step_by(3) {
                for v in 0..=255u8 {
                    for r in [0i32, 1, 17, 128, 254, 255] {
                        let c = classes.class(v, t, r);
                        assert!(c < CLASSES);
                        assert_eq!(classes.key_of(v, t, r), classes.key(c));
                        assert_eq!(
                            classes.key(c),
                            pixel_key(v, t, r, ratio),
                            "ratio {ratio} v {v} t {t} r {r}"
                        );
                    }
                }
            }
        }
    }

    /// The 32-bit gate against comparing the 64-bit keys, at thresholds around every kind of key.
    #[test]
    fn gate_passes_exactly_the_keys_above_the_threshold() {
        for ratio in [0i64, 1, (1 << 24) + 12345, 3 << 25, 1 << 44, i64::MAX] {
            let classes = Classes::new(ratio);
            for threshold in
                [-1i64, 0, 1, 77 << 24, (77 << 24) - 1, (300 << 24) + 5, 1 << 40, i64::MAX - 1, i64::MAX]
            {
                let gate = Gate::new(&classes, threshold);
                for t in (0..=255u8).step_by(5) {
                    for v in (0..=255u8).step_by(3) {
                        for r in [0i32, 1, 17, 128, 255] {
                            let key = classes.key_of(v, t, r);
                            let passes = gate.passes(&classes, v, t, r);
                            // Every key above passes; of the rest only keys saturated at i64::MAX.
                            let what = std::format!("ratio {ratio} threshold {threshold} v {v} t {t} r {r}");
                            assert!(passes || key <= threshold, "{what}: turned away");
                            assert!(!passes || key > threshold || key == i64::MAX, "{what}: let through");
                        }
                    }
                }
            }
        }
    }

    /// The histogram selection against sorting the per-pixel keys.
    #[test]
    fn top_k_sum_matches_sorting() {
        let mut seed = 99u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 33) as u32
        };
        let mut counts = std::vec![0i32; CLASSES];
        let mut work = std::vec![0i32; CLASSES];
        for round in 0..60 {
            let ratio = match round % 5 {
                0 => 0,
                1 => 1 << 24,
                2 => i64::from(next() % (1 << 26)),
                3 => 1 << 44,
                _ => i64::MAX,
            };
            let classes = Classes::new(ratio);
            let n = 1 + (next() as usize % 3000);
            counts.fill(0);
            let mut keys = Vec::new();
            let mut pushed = Vec::new();
            for _ in 0..n {
                // Many ties (a few grey levels) in half the rounds.
                let (v, t, r) = if round % 2 == 0 {
                    ((next() % 256) as u8, (next() % 256) as u8, (next() % 256) as i32)
                } else {
                    ((next() % 3) as u8 * 100, (next() % 2) as u8 * 200, (next() % 2) as i32 * 50)
                };
                counts[classes.class(v, t, r)] += 1;
                keys.push(pixel_key(v, t, r, ratio));
                pushed.push(classes.key_of(v, t, r));
            }
            keys.sort_unstable_by(|a, b| b.cmp(a));
            for k in [0usize, 1, 2, n / 1000 + 1, n / 2, n] {
                // The stream in a buffer from barely above k (a cut every push) to roomy.
                for cap in [k + 1, k + 7, 2 * k + 64] {
                    let mut buf = std::vec![0i32; 2 * cap];
                    let mut top = TopK::new(&mut buf, k).expect("cap > k");
                    for &key in &pushed {
                        top.push(key);
                    }
                    let want: i128 = keys.iter().take(k).map(|&x| i128::from(x)).sum();
                    assert_eq!(top.sum(), want, "stream: round {round} n {n} k {k} cap {cap}");
                }
            }
            for k in [0usize, 1, 2, n / 1000 + 1, n / 2, n, n + 3] {
                let want: i128 = keys.iter().take(k).map(|&x| i128::from(x)).sum();
                assert_eq!(
                    top_k_sum(&counts, &classes, k as u64, &mut work),
                    want,
                    "round {round} n {n} k {k}"
                );
            }
        }
    }
}
