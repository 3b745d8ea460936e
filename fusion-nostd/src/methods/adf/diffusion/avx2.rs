//! The AVX2 form of the row loop (x86-64 hosts without AVX-512): [`Lanes`] on eight pixels ×
//! two bands (16 lanes of `i16`) for the loop of `simd.rs`. AVX2 has no permute of 16-bit words
//! over 64 entries (AVX-512's `vpermi2w`), so the flux function's 64 segments are held as
//! 64-entry byte tables (the nodes' low bytes, their high bytes when a node does not fit a
//! byte, the rises) and read with `vpshufb`. Two fluxes are looked up together: their segment
//! indices packed into the 32 bytes of one register, each table is read for 32 lanes by four
//! shuffles chained with XOR (the quarters `T₀, T₀⊕T₁, T₁⊕T₂, T₂⊕T₃` on the index less 0, 16,
//! 32, 48: `vpshufb` gives 0 where the index byte is negative, so the XOR of the terms that
//! remain telescopes to `T_q`), and the bytes are interleaved back into 16-bit lanes. With
//! the published parameters every node fits a byte: 8 shuffles per 32 fluxes (session 15's
//! form: 24 shuffles and 20 blends per 32; the first AVX2 form, two `vpgatherdd` of the
//! 128 KiB table per 16). A block whose four fluxes all lie in the first 16 segments (most of
//! a real frame's blocks) reads the first 16 bases and slopes instead, 4 shuffles per 32 fluxes
//! and no clamp ([`Flux::apply4`]): the frame decides the time, not the values (BENCHMARKS.md
//! gives a uniform-noise frame's). The same values as the portable loop, so the same bits (checked by
//! `simd_rows_equal_the_portable_rows` and `table_and_avx512_equal_the_function_exhaustively`).

use super::super::avx2::words as load;
#[cfg(doc)]
use super::flux::ByteTables;
use super::flux::{FluxFn, SEGMENTS};
use super::row::RowCarry;
use super::simd::{Lanes, row_blocks as blocks};
use core::arch::x86_64::*;

/// Stores eight words to `s[at..at + 8]`.
#[target_feature(enable = "avx2")]
#[inline]
fn store(s: &mut [i32], at: usize, x: __m256i) -> Option<()> {
    let v: &mut [i32; 8] = s.get_mut(at..at + 8)?.try_into().ok()?;
    // SAFETY: writes the 32 bytes of `v` (unaligned store).
    unsafe { _mm256_storeu_si256(v.as_mut_ptr().cast(), x) };
    Some(())
}

/// `[prev[8 − k..], cur[..8 − k]]` in words: `cur` shifted up by `k` words (`BYTES` =
/// 16 − 4k), the vacated words taken from the top of `prev`.
#[target_feature(enable = "avx2")]
#[inline]
fn shift_in<const BYTES: i32>(prev: __m256i, cur: __m256i) -> __m256i {
    _mm256_alignr_epi8::<BYTES>(cur, _mm256_permute2x128_si256::<0x21>(prev, cur))
}

/// A 64-entry byte table `T` as its quarters `T₀, T₀⊕T₁, T₁⊕T₂, T₂⊕T₃` (16 bytes each).
type Chained = [[u8; 16]; 4];

/// [`Chained`] quarters of `t`.
fn chained(t: &[u8; SEGMENTS]) -> Chained {
    let quarter = |q: usize| -> [u8; 16] {
        t.get(16 * q..16 * q + 16).and_then(|c| c.try_into().ok()).unwrap_or([0; 16])
    };
    core::array::from_fn(|q| {
        let mut x = quarter(q);
        if let Some(before) = q.checked_sub(1) {
            x.iter_mut().zip(quarter(before)).for_each(|(x, b)| *x ^= b);
        }
        x
    })
}

/// Sixteen bytes in both 128-bit halves (`vpshufb` looks up within a half).
#[target_feature(enable = "avx2")]
#[inline]
fn both_halves(b: &[u8; 16]) -> __m256i {
    // SAFETY: reads the 16 bytes of `b`.
    _mm256_broadcastsi128_si256(unsafe { _mm_loadu_si128(b.as_ptr().cast()) })
}

/// A [`Chained`] table in registers.
#[derive(Clone, Copy)]
struct Bytes([__m256i; 4]);

impl Bytes {
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(t: &Chained) -> Self {
        Bytes(t.map(|q| both_halves(&q)))
    }

    /// Entry `j` in every byte that holds `j` (0..64) in `idx[0]`; `idx[q]` is `idx[0] − 16q`
    /// (bytes). For `j` in quarter `q` the terms `q' > q` read a negative index (0) and the
    /// terms `q' ≤ q` are `T₀ ⊕ (T₀⊕T₁) ⊕ … ⊕ (T_{q−1}⊕T_q) = T_q` at `j mod 16`.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn lookup(&self, idx: &[__m256i; 4]) -> __m256i {
        let [t0, t1, t2, t3] = self.0;
        let [i0, i1, i2, i3] = *idx;
        let low = _mm256_xor_si256(_mm256_shuffle_epi8(t0, i0), _mm256_shuffle_epi8(t1, i1));
        let high = _mm256_xor_si256(_mm256_shuffle_epi8(t2, i2), _mm256_shuffle_epi8(t3, i3));
        _mm256_xor_si256(low, high)
    }
}

/// The flux function as the AVX2 loop's byte tables, built once per call: [`ByteTables`]
/// ([`Chained`]) and the first 16 bases and slopes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Tables {
    limit: i16,
    shift: u32,
    /// `max(k − 7, 0)` ([`ByteTables`]).
    rise_shift: u32,
    node_lo: Chained,
    node_hi: Option<Chained>,
    rise: Chained,
    /// Segments 0..16 as [`FluxFn::magnitude`] reads them: the bases' low and high bytes, the
    /// slopes' low and high bytes.
    first: [[u8; 16]; 4],
}

impl Tables {
    /// The tables of `fx` ([`FluxFn::byte_tables`], chained), `None` as those.
    pub(super) fn new(fx: &FluxFn) -> Option<Self> {
        let b = fx.byte_tables()?;
        // The low (`high` false) or high bytes of segments 0..16 of `t`.
        let first = |t: &[i16; SEGMENTS], high: bool| {
            let mut out = [0u8; 16];
            for (o, &v) in out.iter_mut().zip(t) {
                *o = if high { (v >> 8) as u8 } else { v as u8 };
            }
            out
        };
        Some(Tables {
            first: [
                first(&fx.base, false),
                first(&fx.base, true),
                first(&fx.slope, false),
                first(&fx.slope, true),
            ],
            limit: fx.limit as i16,
            shift: fx.shift,
            rise_shift: b.rise_shift,
            node_lo: chained(&b.node_lo),
            node_hi: b.node_hi.as_ref().map(chained),
            rise: chained(&b.rise),
        })
    }

    /// Whether the nodes take two bytes (for the tests).
    #[cfg(test)]
    pub(super) fn two_byte_nodes(&self) -> bool {
        self.node_hi.is_some()
    }
}

/// The flux function in registers ([`Tables`] read by `vpshufb`); `WIDE`: the nodes take two
/// bytes.
struct Flux<const WIDE: bool> {
    limit: __m256i,
    /// `k`.
    shift: __m128i,
    /// `max(k − 7, 0)`: the rise byte, moved to the high byte, shifted right by this is the
    /// slope of the Q15 product.
    rise_shift: __m128i,
    /// `2ᵏ − 1`: `q = m mod 2ᵏ`.
    low_bits: __m256i,
    node_lo: Bytes,
    /// The nodes' high bytes (`WIDE` only).
    node_hi: Bytes,
    rise: Bytes,
    /// [`Tables::first`] (in both 128-bit halves).
    first: [__m256i; 4],
}

impl<const WIDE: bool> Flux<WIDE> {
    #[target_feature(enable = "avx2")]
    #[inline]
    fn new(t: &Tables) -> Self {
        Flux {
            limit: _mm256_set1_epi16(t.limit),
            shift: _mm_cvtsi32_si128(t.shift as i32),
            rise_shift: _mm_cvtsi32_si128(t.rise_shift as i32),
            low_bits: _mm256_set1_epi16(((1u32 << t.shift) - 1) as i16),
            node_lo: Bytes::new(&t.node_lo),
            node_hi: Bytes::new(&t.node_hi.unwrap_or_default()),
            rise: Bytes::new(&t.rise),
            first: t.first.map(|b| both_halves(&b)),
        }
    }

    /// The segments `j = m >> k` of the magnitudes `ma` and `mb` (16-bit lanes) as the bytes of
    /// one register (`vpackuswb`, per 128-bit half `ma`'s eight, then `mb`'s; a `j` above 255
    /// reads 255).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn segments(&self, ma: __m256i, mb: __m256i) -> __m256i {
        _mm256_packus_epi16(_mm256_srl_epi16(ma, self.shift), _mm256_srl_epi16(mb, self.shift))
    }

    /// The fluxes of the differences `a` and `b` from their magnitudes `ma`, `mb` (clamped to
    /// the limit) and `read`, which gives a table's entries at their segments (the bytes of
    /// [`Flux::segments`]): `n_j + ⌊(q·ρ_j + 2^(k−1)) / 2ᵏ⌋` with `q = m mod 2ᵏ` (the rounded
    /// Q15 product `vpmulhrsw(q, ρ_j·2^(15−k))`, the portable `mulhrs` of `m` less `j·ρ_j`;
    /// see [`FluxFn::magnitude`]), the sign of `∇` back (`vpsignw`; `F(0) = n_0 = 0`).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn finish(
        &self,
        [a, b]: [__m256i; 2],
        [ma, mb]: [__m256i; 2],
        read: impl Fn(&Bytes) -> __m256i,
    ) -> [__m256i; 2] {
        let rise = read(&self.rise);
        let node = read(&self.node_lo);
        // Per lane the node (sign-extended) and the rise in the high byte (`ρ·2⁸` scaled).
        let (na, nb, ra, rb) = if WIDE {
            let hi = read(&self.node_hi);
            let zero = _mm256_setzero_si256();
            (
                _mm256_unpacklo_epi8(node, hi),
                _mm256_unpackhi_epi8(node, hi),
                _mm256_unpacklo_epi8(zero, rise),
                _mm256_unpackhi_epi8(zero, rise),
            )
        } else {
            let (wa, wb) = (_mm256_unpacklo_epi8(rise, node), _mm256_unpackhi_epi8(rise, node));
            (
                _mm256_srai_epi16::<8>(wa),
                _mm256_srai_epi16::<8>(wb),
                _mm256_slli_epi16::<8>(wa),
                _mm256_slli_epi16::<8>(wb),
            )
        };
        let flux = |m: __m256i, d: __m256i, node: __m256i, rise: __m256i| {
            let slope = _mm256_sra_epi16(rise, self.rise_shift);
            let q = _mm256_and_si256(m, self.low_bits);
            _mm256_sign_epi16(_mm256_add_epi16(node, _mm256_mulhrs_epi16(q, slope)), d)
        };
        [flux(ma, a, na, ra), flux(mb, b, nb, rb)]
    }

    /// [`FluxFn::eval`] on the sixteen differences of `a` and of `b` (each in
    /// `−32767..=32767`): `m = min(|∇|, limit)`, its segment `j`, every table read for both
    /// at once.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn apply2(&self, a: __m256i, b: __m256i) -> [__m256i; 2] {
        let m = [a, b].map(|d| _mm256_min_epu16(_mm256_abs_epi16(d), self.limit));
        let j = self.segments(m[0], m[1]);
        let idx = [0, 16, 32, 48].map(|o| _mm256_sub_epi8(j, _mm256_set1_epi8(o)));
        self.finish([a, b], m, |t| t.lookup(&idx))
    }

    /// [`FluxFn::eval`] on four registers. When every segment is below 16 (differences below
    /// 32 grey levels at the published κ: most of a natural frame's), `|∇| < 16·2ᵏ ≤ limit`
    /// needs no clamp and the function is read as [`FluxFn::magnitude`] reads it, `base_j +
    /// r(m, slope_j)`, from the first 16 bases and slopes (one shuffle per byte and pair);
    /// otherwise [`Flux::apply2`] on both pairs. The same values either way (the time
    /// depends on the frame: BENCHMARKS.md gives a noise frame's).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn apply4(&self, [a, b, c, d]: [__m256i; 4]) -> [__m256i; 4] {
        let [ma, mb, mc, md] = [a, b, c, d].map(|x| _mm256_abs_epi16(x));
        let (jab, jcd) = (self.segments(ma, mb), self.segments(mc, md));
        if _mm256_testz_si256(_mm256_or_si256(jab, jcd), _mm256_set1_epi8(0xF0u8 as i8)) != 0 {
            let first = |j: __m256i, [a, b]: [__m256i; 2], [ma, mb]: [__m256i; 2]| {
                let [bl, bh, sl, sh] = self.first.map(|t| _mm256_shuffle_epi8(t, j));
                let f = |m, d, base, slope| {
                    _mm256_sign_epi16(_mm256_add_epi16(base, _mm256_mulhrs_epi16(m, slope)), d)
                };
                let fa = f(ma, a, _mm256_unpacklo_epi8(bl, bh), _mm256_unpacklo_epi8(sl, sh));
                [fa, f(mb, b, _mm256_unpackhi_epi8(bl, bh), _mm256_unpackhi_epi8(sl, sh))]
            };
            let [fa, fb] = first(jab, [a, b], [ma, mb]);
            let [fc, fd] = first(jcd, [c, d], [mc, md]);
            [fa, fb, fc, fd]
        } else {
            let [fa, fb] = self.apply2(a, b);
            let [fc, fd] = self.apply2(c, d);
            [fa, fb, fc, fd]
        }
    }
}

/// [`FluxFn::eval`] by the AVX2 form ([`Flux::apply4`]) on four registers of sixteen values
/// (for the tests); `None` as [`Tables::new`].
///
/// # Safety
/// The CPU must support AVX2.
#[cfg(test)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn flux_four(fx: &FluxFn, x: [[i16; 16]; 4]) -> Option<[[i16; 16]; 4]> {
    let t = Tables::new(fx)?;
    // SAFETY: reads the 32 bytes of each `x[i]`.
    let v = x.map(|x| unsafe { _mm256_loadu_si256(x.as_ptr().cast()) });
    let f = match t.node_hi {
        Some(_) => Flux::<true>::new(&t).apply4(v),
        None => Flux::<false>::new(&t).apply4(v),
    };
    Some(f.map(|f| {
        let mut out = [0i16; 16];
        // SAFETY: writes the 32 bytes of `out`.
        unsafe { _mm256_storeu_si256(out.as_mut_ptr().cast(), f) };
        out
    }))
}

impl<const WIDE: bool> Lanes for Flux<WIDE> {
    type V = __m256i;
    const WORDS: usize = 8;

    // SAFETY (every method): a `Flux` is built only by `Flux::new`, compiled for AVX2, so the
    // CPU has AVX2.
    #[inline(always)]
    fn zero(&self) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_setzero_si256() }
    }

    #[inline(always)]
    fn top(&self, w: i32) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_set_epi32(w, 0, 0, 0, 0, 0, 0, 0) }
    }

    #[inline(always)]
    fn load(&self, s: &[i32]) -> __m256i {
        // SAFETY: see above.
        unsafe { load(s, 0) }.unwrap_or_else(|| self.zero())
    }

    #[inline(always)]
    fn store(&self, s: &mut [i32], at: usize, x: __m256i) -> Option<()> {
        // SAFETY: see above.
        unsafe { store(s, at, x) }
    }

    #[inline(always)]
    fn word(&self, x: __m256i, i: usize) -> i32 {
        let mut l = [0i32; 8];
        // SAFETY: see above; writes the 32 bytes of `l`.
        unsafe { _mm256_storeu_si256(l.as_mut_ptr().cast(), x) };
        l.get(i).copied().unwrap_or(0)
    }

    #[inline(always)]
    fn flux(&self, d: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { self.apply2(d, d)[0] }
    }

    #[inline(always)]
    fn flux4(&self, x: [__m256i; 4], c: __m256i) -> [__m256i; 4] {
        // SAFETY: see above.
        unsafe { self.apply4(x.map(|x| _mm256_sub_epi16(x, c))) }
    }

    #[inline(always)]
    fn sub(&self, a: __m256i, b: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_sub_epi16(a, b) }
    }

    #[inline(always)]
    fn adds(&self, a: __m256i, b: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_adds_epi16(a, b) }
    }

    #[inline(always)]
    fn subs(&self, a: __m256i, b: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_subs_epi16(a, b) }
    }

    #[inline(always)]
    fn max0(&self, a: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe { _mm256_max_epi16(a, _mm256_setzero_si256()) }
    }

    #[inline(always)]
    fn up<const K: usize>(&self, prev: __m256i, cur: __m256i) -> __m256i {
        // SAFETY: see above.
        unsafe {
            match K {
                1 => shift_in::<12>(prev, cur),
                _ => shift_in::<8>(prev, cur),
            }
        }
    }
}

/// Runs the row loop of `Diffusion::row` (`simd.rs`) on whole blocks of eight pixels from the
/// start of the row with the flux function's tables `t`, updating `carry`; returns the pixels
/// done.
///
/// # Safety
/// The CPU must support AVX2.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn row_blocks(
    t: &Tables,
    p: &[i32],
    q: &[i32],
    north: &mut [i32],
    out: &mut [i32],
    carry: &mut RowCarry,
) -> usize {
    match t.node_hi {
        Some(_) => blocks(&Flux::<true>::new(t), p, q, north, out, carry),
        None => blocks(&Flux::<false>::new(t), p, q, north, out, carry),
    }
}
