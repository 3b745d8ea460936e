//! One row of one iteration: the per-call constants [`Diffusion`] (the flux function, the
//! border rule, which row loop runs), the portable row loop by pair fluxes ([`Diffusion::row`])
//! and its hand-over to the instruction-set loops (`simd.rs` with `avx2.rs`, `avx512.rs` and
//! `neon.rs`; `armv7em.rs`), which carry a [`RowCarry`] in and out; and the plain update of
//! one pixel with all eight fluxes ([`Diffusion::iterate`]) for frames too small for the row
//! pipeline.

use super::super::AdfParams;
use super::STATE_MAX;
#[cfg(fusion_arm_dsp)]
use super::armv7em;
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
use super::flux::ByteTables;
use super::flux::{FluxFn, FluxSource, Table};
#[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
use super::neon;
use super::pack::{half, hi, lo, pack};
#[cfg(target_arch = "x86_64")]
use super::{avx2, avx512};
use crate::filters::border::Border;

/// What the row loop carries from one pixel to the next, both bands per word: the previous
/// east flux (this pixel's west, negated), the previous south-east flux, and
/// `2·v(i−1) + dr(i−2)`.
#[derive(Debug, Clone, Copy)]
pub(super) struct RowCarry {
    pub(super) h_prev: i32,
    pub(super) dr_prev: i32,
    pub(super) partial: i32,
}

/// Per-call constants of the diffusion.
#[derive(Debug, Clone, Copy)]
pub(super) struct Diffusion {
    pub(super) fx: FluxFn,
    pub(super) border: Border,
    /// Use the AVX-512 row loop (x86-64 with AVX-512 F, BW and VL).
    #[cfg(target_arch = "x86_64")]
    pub(super) avx512: bool,
    /// Else use the AVX2 row loop (x86-64 with AVX2, and `avx2_tables` built).
    #[cfg(target_arch = "x86_64")]
    pub(super) avx2: bool,
    /// The AVX2 loop's byte tables of `fx`.
    #[cfg(target_arch = "x86_64")]
    pub(super) avx2_tables: Option<avx2::Tables>,
    /// Use the NEON row loop (AArch64, unless `cpu::limit_isa` capped it, and `neon_tables`
    /// built).
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    pub(super) neon: bool,
    /// The NEON loop's byte tables of `fx`.
    #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
    pub(super) neon_tables: Option<ByteTables>,
}

/// One band's part of the row update: the step `Σ = 2·(h + v − h_prev) + (dr + dl − north)`
/// (exact: no rounding, so it is odd in the fluxes — a band and its negative `255 − I` diffuse
/// to exact negatives while no state is clamped, see the [module docs](super)). No partial sum
/// here or in the north sums exceeds `12·|F|max ≤ 12·1760 < 2¹⁵`
/// ([`MAX_FLUX`](super::flux::MAX_FLUX)), so the 16-bit lanes of the Armv7E-M and AVX-512 loops
/// (saturating instructions, for defence) compute the same values as these plain sums.
#[inline(always)]
fn update_band(c: i32, [h, v, dr, dl]: [i32; 4], h_prev: i32, n: i32) -> i32 {
    let step = 2 * (h + v - h_prev) + (dr + dl - n);
    (c + step).clamp(0, STATE_MAX)
}

/// One pixel of one band in the portable row loop: the four pair fluxes, the next state, the
/// north sum of the pixel below-left (returned) and the carried values.
#[inline(always)]
fn band_pixel<F: FluxSource>(
    f: &F,
    c: i32,
    [pr, qc, qr, ql]: [i32; 4],
    n: i32,
    [h_prev, dr_prev, partial]: &mut [i32; 3],
) -> (i32, i32) {
    let (h, v, dr, dl) = (f.flux(pr - c), f.flux(qc - c), f.flux(qr - c), f.flux(ql - c));
    let next = update_band(c, [h, v, dr, dl], *h_prev, n);
    let below = *partial + dl;
    *partial = 2 * v + *dr_prev;
    *dr_prev = dr;
    *h_prev = h;
    (next, below)
}

impl Diffusion {
    pub(super) fn new(params: &AdfParams) -> Self {
        let fx = FluxFn::new(params);
        #[cfg(target_arch = "x86_64")]
        let avx2_tables = avx2::Tables::new(&fx);
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        let neon_tables = fx.byte_tables();
        Self {
            fx,
            border: params.border(),
            #[cfg(target_arch = "x86_64")]
            avx512: crate::cpu::has_avx512bw(),
            #[cfg(target_arch = "x86_64")]
            avx2: crate::cpu::has_avx2() && avx2_tables.is_some(),
            #[cfg(target_arch = "x86_64")]
            avx2_tables,
            #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
            neon: crate::cpu::has_neon() && neon_tables.is_some(),
            #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
            neon_tables,
        }
    }

    /// Whether the row loops here read a table (false: the AVX-512, AVX2 and NEON loops keep
    /// the function in registers).
    pub(super) fn wants_table(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx512 || self.avx2 {
            return false;
        }
        // The NEON loop keeps the function in registers too.
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        if self.neon {
            return false;
        }
        true
    }

    /// The next iterate of one pixel (both bands) from its 3×3 neighbourhood (columns left,
    /// centre, right, each top to bottom) with all eight fluxes: the path for frames too
    /// small for the row pipeline. The north sum and the west flux are formed exactly as the
    /// row pipeline forms them, so both give the same bits.
    fn update<F: FluxSource>(&self, f: &F, [l, c, r]: [[i32; 3]; 3]) -> i32 {
        let out = [0, 1].map(|b| {
            let band = |w: i32| half(w, b);
            let centre = band(c[1]);
            let later = |w: i32| f.flux(band(w) - centre);
            let earlier = |w: i32| f.flux(centre - band(w));
            let north = 2 * earlier(c[0]) + earlier(l[0]) + earlier(r[0]);
            update_band(centre, [later(r[1]), later(c[2]), later(r[2]), later(l[2])], earlier(l[1]), north)
        });
        pack(out[0], out[1])
    }

    /// One Jacobi iteration of the packed `w`-wide plane `src` into `dst`.
    pub(super) fn iterate<F: FluxSource>(&self, f: &F, src: &[i32], dst: &mut [i32], w: usize) {
        let h = src.len() / w.max(1);
        for (y, out) in dst.chunks_exact_mut(w.max(1)).enumerate() {
            let row = |yy: usize| src.get(yy * w..yy * w + w);
            let Some(mid) = row(y) else { return };
            let (up, down) = match self.border {
                Border::Replicate => (row(y.saturating_sub(1)), row((y + 1).min(h - 1))),
                _ => (y.checked_sub(1).and_then(row), row(y + 1)),
            };
            crate::filters::border::map_neighbourhoods(up, mid, down, self.border, out.iter_mut(), |n, o| {
                *o = self.update(f, n)
            });
        }
    }

    /// The north fluxes of the top pad row `top` with every pixel of the first row `q` (both
    /// padded, `w + 2` long), into `north[1..=w]`, as the row loop forms them.
    pub(super) fn top_north<F: FluxSource>(&self, f: &F, top: &[i32], q: &[i32], north: &mut [i32]) {
        let pixels = top.windows(3).zip(q.iter().skip(1)).zip(north.iter_mut().skip(1));
        for ((t, &c), n) in pixels {
            if let &[nw, n0, ne] = t {
                let band = |b: usize| {
                    let cb = half(c, b);
                    let fl = |w: i32| f.flux(cb - half(w, b));
                    2 * fl(n0) + fl(nw) + fl(ne)
                };
                *n = pack(band(0), band(1));
            }
        }
    }

    /// One output row of a Jacobi iteration by pair fluxes. `p` is the row being updated and
    /// `q` the row below, both padded by one column on each side (`w + 2`); `north[i]` holds
    /// the north sums of pixel `i` of `p` (`2·F(C − N) + F(C − NW) + F(C − NE)`,
    /// subtracted) and is replaced by those of `q`. Per pixel and band four fluxes: the pairs
    /// east (`h`), south (`v`), south-east (`dr`) and south-west (`dl`), each `F(later −
    /// earlier)`. Each enters this pixel's sum and, negated, its partner's: the west flux is
    /// the previous pixel's `h`, and the pairs to `q` become `q`'s north sums. The next
    /// iterate goes to `out` (`w`).
    #[inline(never)]
    pub(super) fn row(
        &self,
        table: Option<&[i16]>,
        p: &[i32],
        q: &[i32],
        north: &mut [i32],
        out: &mut [i32],
    ) {
        match table {
            Some(t) => self.row_with(&Table(t), p, q, north, out),
            None => self.row_with(&self.fx, p, q, north, out),
        }
    }

    #[inline(always)]
    fn row_with<F: FluxSource>(&self, f: &F, p: &[i32], q: &[i32], north: &mut [i32], out: &mut [i32]) {
        let fl = |a: i32, b: i32| pack(f.flux(lo(b) - lo(a)), f.flux(hi(b) - hi(a)));
        let (Some(&p0), Some(&p1), Some(&q1)) = (p.first(), p.get(1), q.get(1)) else { return };
        // The left pad's pairs: p[0]–p[1] (the first west flux) and p[0]–q[1].
        #[cfg_attr(
            not(any(
                target_arch = "x86_64",
                fusion_arm_dsp,
                all(target_arch = "aarch64", target_feature = "neon")
            )),
            allow(unused_mut)
        )]
        let mut carry = RowCarry { h_prev: fl(p0, p1), dr_prev: fl(p0, q1), partial: 0 };
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `avx512` is set only when the CPU has AVX-512 F, BW and VL, `avx2` only when
        // it has AVX2 (checked at run time).
        let done = if self.avx512 {
            unsafe { avx512::row_blocks(&self.fx, p, q, north, out, &mut carry) }
        } else if let (true, Some(t)) = (self.avx2, &self.avx2_tables) {
            unsafe { avx2::row_blocks(t, p, q, north, out, &mut carry) }
        } else {
            0
        };
        #[cfg(fusion_arm_dsp)]
        let done = match f.table() {
            Some(t) => armv7em::row_pixels(t, p, q, north, out, &mut carry),
            None => 0,
        };
        #[cfg(all(target_arch = "aarch64", target_feature = "neon"))]
        let done = match (self.neon, &self.neon_tables) {
            (true, Some(t)) => {
                neon::row_blocks(t, (self.fx.limit, self.fx.shift), p, q, north, out, &mut carry)
            }
            _ => 0,
        };
        #[cfg(not(any(
            target_arch = "x86_64",
            fusion_arm_dsp,
            all(target_arch = "aarch64", target_feature = "neon")
        )))]
        let done = 0;
        let mut bands = [0, 1].map(|b| [carry.h_prev, carry.dr_prev, carry.partial].map(|w| half(w, b)));
        let north = core::cell::Cell::from_mut(north).as_slice_of_cells();
        // The rest of the row from pixel `done` (padded index done + 1).
        let (Some(pd), Some(qd), Some(nd), Some(od)) =
            (p.get(done..), q.get(done..), north.get(done..), out.get_mut(done..))
        else {
            return;
        };
        let pixels = pd.windows(2).skip(1).zip(qd.windows(3)).zip(nd.windows(2)).zip(od.iter_mut());
        for (((pw, qw), nw), o) in pixels {
            let (&[pc, pr], &[ql, qc, qr], [n_prev, n_here]) = (pw, qw, nw) else { continue };
            let n = n_here.get();
            let [b0, b1] = &mut bands;
            let (o0, s0) = band_pixel(f, lo(pc), [lo(pr), lo(qc), lo(qr), lo(ql)], lo(n), b0);
            let (o1, s1) = band_pixel(f, hi(pc), [hi(pr), hi(qc), hi(qr), hi(ql)], hi(n), b1);
            *o = pack(o0, o1);
            n_prev.set(pack(s0, s1));
        }
        // The right pad's pair p[w+1]–q[w] completes q's last north sums.
        let n = p.len();
        if let (Some(last), Some(&pr), Some(&ql)) =
            (north.get(n.wrapping_sub(2)), p.get(n.wrapping_sub(1)), q.get(n.wrapping_sub(2)))
        {
            let [[_, _, s0], [_, _, s1]] = bands;
            last.set(pack(s0 + f.flux(lo(ql) - lo(pr)), s1 + f.flux(hi(ql) - hi(pr))));
        }
    }
}
