//! Exact sum of the `k` largest keys without sorting: histogram selection.
//!
//! The keys sit in two caller planes (low and high 32 bits, [`store`]). Pass 1 histograms
//! their integer grey level (`key >> 24`, the top bin open-ended) and finds the bin holding the
//! k-th largest key. Pass 2 adds up every key above that bin (`i128`) and compacts the keys
//! inside it to the front of the planes. The candidates are then refined with 1024-bin histograms over their own range — each round
//! adds the keys above the selected bin and keeps the ones in it — until the bin holds one
//! value `T`; the sum is `Σ above + (k − #above)·T`. Two passes over the keys, then a few
//! over the candidates (usually a few hundred); no sort, exact for any key distribution.
//! IFEVIP counts pass 1 while it stores the keys ([`top_k_sum_with`]), so only pass 2 reads
//! them back.

/// Bins per histogram.
pub const BINS: usize = 1024;

/// Fractional bits of the keys.
pub const KEY_BITS: u32 = 24;

#[inline]
fn pack(key: i64) -> (i32, i32) {
    (key as u32 as i32, (key >> 32) as i32)
}

#[inline]
fn unpack(lo: i32, hi: i32) -> i64 {
    (i64::from(hi) << 32) | i64::from(lo as u32)
}

/// The bin (from the top) where the cumulative count reaches `need`, and the count above it.
fn select(hist: &[u32; BINS], need: u64) -> (usize, u64) {
    let mut above = 0u64;
    for (b, &c) in hist.iter().enumerate().rev() {
        if above + u64::from(c) >= need {
            return (b, above);
        }
        above += u64::from(c);
    }
    (0, above)
}

/// Stores a key as two `i32` plane elements (low and high 32 bits).
#[inline(always)]
pub fn store(key: i64, lo: &mut i32, hi: &mut i32) {
    let (l, h) = pack(key);
    *lo = l;
    *hi = h;
}

/// The coarse histogram of pass 1: one bin per integer grey level of the key (`key >> 24`),
/// the top bin open-ended.
pub type Coarse = [u32; BINS];

/// The coarse bin of a key (see [`Coarse`]).
#[inline(always)]
pub fn coarse_bin(key: i64) -> usize {
    ((key.max(0) >> KEY_BITS) as u64).min(BINS as u64 - 1) as usize
}

/// Sum of the `k` largest of the `n` non-negative keys held in `lo_plane`/`hi_plane` (see
/// [`store`]); the planes are reordered. `k = 0` gives 0; `k ≥ n` sums all keys.
pub fn top_k_sum(lo_plane: &mut [i32], hi_plane: &mut [i32], n: usize, k: u64) -> i128 {
    let n = n.min(lo_plane.len()).min(hi_plane.len());
    let mut hist = [0u32; BINS];
    for (&l, &h) in lo_plane.iter().zip(hi_plane.iter()).take(n) {
        if let Some(c) = hist.get_mut(coarse_bin(unpack(l, h))) {
            *c = c.wrapping_add(1);
        }
    }
    top_k_sum_with(lo_plane, hi_plane, n, k, &hist)
}

/// [`top_k_sum`] with pass 1 done by the caller: `hist` is the [`Coarse`] histogram of the
/// `n` keys (e.g. counted while storing them).
pub fn top_k_sum_with(lo_plane: &mut [i32], hi_plane: &mut [i32], n: usize, k: u64, hist: &Coarse) -> i128 {
    let n = n.min(lo_plane.len()).min(hi_plane.len());
    let k = k.min(n as u64);
    if k == 0 {
        return 0;
    }
    let (t, above) = select(hist, k);
    let mut need = k - above;
    let mut sum: i128 = 0;
    // The selected bin is [lo, lo + 2^shift), open-ended when it is the top coarse bin.
    let mut lo = (t as i64) << KEY_BITS;
    let mut shift = KEY_BITS;
    let mut open = t == BINS - 1;
    let mut n = n;
    loop {
        // Add the keys above the bin, keep (compacted to the front) the ones in it.
        let mut kept = 0usize;
        let mut hi = i64::MIN;
        for i in 0..n {
            let key = match (lo_plane.get(i), hi_plane.get(i)) {
                (Some(&l), Some(&h)) => unpack(l, h),
                _ => break,
            };
            if key < lo {
                continue;
            }
            if !open && ((key - lo) as u64) >> shift > 0 {
                sum += i128::from(key);
            } else {
                if let (Some(pl), Some(ph)) = (lo_plane.get_mut(kept), hi_plane.get_mut(kept)) {
                    store(key, pl, ph);
                }
                kept += 1;
                hi = hi.max(key);
            }
        }
        n = kept;
        if n == 0 || hi <= lo {
            break;
        }
        // Refine: at most 1024 bins over [lo, hi].
        let span = (hi - lo) as u64;
        shift = (64 - span.leading_zeros()).saturating_sub(BINS.trailing_zeros());
        let mut hist = [0u32; BINS];
        for (&l, &h) in lo_plane.iter().zip(hi_plane.iter()).take(n) {
            let bin = ((unpack(l, h) - lo) as u64 >> shift) as usize;
            if let Some(c) = hist.get_mut(bin) {
                *c += 1;
            }
        }
        let (t2, above2) = select(&hist, need);
        need -= above2;
        lo += (t2 as i64) << shift;
        open = false;
    }
    sum + i128::from(need) * i128::from(lo)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn brute(keys: &[i64], k: usize) -> i128 {
        let mut v = [0i64; 64];
        let n = keys.len();
        v[..n].copy_from_slice(keys);
        v[..n].sort_unstable_by(|a, b| b.cmp(a));
        v[..k.min(n)].iter().map(|&x| i128::from(x)).sum()
    }

    #[test]
    fn matches_sorting() {
        let mut seed = 99u64;
        let mut lo = [0i32; 64];
        let mut hi = [0i32; 64];
        for round in 0..200 {
            let n = 1 + round % 64;
            let mut keys = [0i64; 64];
            for k in keys.iter_mut().take(n) {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                *k = match round % 4 {
                    0 => (seed >> 30) as i64 & ((1 << 34) - 1),
                    1 => (((seed >> 40) % 3) as i64) << 24, // many ties
                    2 => (seed >> 8) as i64 & ((1 << 55) - 1), // huge keys
                    _ => 7,
                };
            }
            for k in [0usize, 1, 2, n / 2, n, n + 3] {
                for (i, &key) in keys.iter().enumerate().take(n) {
                    store(key, &mut lo[i], &mut hi[i]);
                }
                let got = top_k_sum(&mut lo, &mut hi, n, k as u64);
                assert_eq!(got, brute(&keys[..n], k), "round {round} n {n} k {k}");
            }
        }
    }
}
