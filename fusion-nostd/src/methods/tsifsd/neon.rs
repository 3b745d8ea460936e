//! The NEON form of the flight kernel's chunk (AArch64: Cortex-A53/A72 class, Arm hosts): eight
//! pixels per step, the formulas of [`chunk_portable`] lane by lane. The window sums `dd` as a
//! prefix sum of `enter − leave` in registers; `⌊dd/c⌋` and the output's `⌊·/c⌋` by [`MagicC`]
//! (`sqdmulh`, a shift); the Scharr gradients of both bands on the 16-bit lanes of the column
//! words ([`scharr_columns_pair`]), where `abs` is one instruction; `⌊·/σ⌋` as the `f32`
//! quotient truncated (`fdiv`, `fcvtzu`: exact, see [`div_sigma_f32`]); the clamp to `0..=255` by
//! the saturating narrows. The chunk's last `n mod 8` pixels take [`chunk_portable`]. The same
//! bytes and flags as the portable chunk (the SIMD-forms test under `qemu-aarch64`, and the
//! bit-exactness jobs of `fusion budget --target a53`). The kernel's two row loops have NEON
//! forms too: [`lane_pairs`] (a frame row pair into lane words) and [`column_steps`] (the
//! window's column sums, one row in and one out).

use super::*;
use core::arch::aarch64::*;

/// `dst[x] = lane_pair(vis[x], tir[x])` (VIS + IR·2¹⁶) over the shortest of the three, eight
/// words per step (`zip` of the widened bytes).
pub(super) fn lane_pairs(dst: &mut [i32], vis: &[u8], tir: &[u8]) {
    let n = dst.len().min(vis.len()).min(tir.len());
    let mut x = 0;
    while x + 8 <= n {
        let (Some(o), Some(v), Some(t)) = (
            dst.get_mut(x..x + 8).and_then(|s| <&mut [i32; 8]>::try_from(s).ok()),
            vis.get(x..x + 8).and_then(|s| <&[u8; 8]>::try_from(s).ok()),
            tir.get(x..x + 8).and_then(|s| <&[u8; 8]>::try_from(s).ok()),
        ) else {
            break;
        };
        // SAFETY: NEON; reads the 8 bytes of `v` and `t`, writes the 32 bytes of `o`.
        unsafe {
            let (v, t) = (vmovl_u8(vld1_u8(v.as_ptr())), vmovl_u8(vld1_u8(t.as_ptr())));
            vst1q_u16(o.as_mut_ptr().cast(), vzip1q_u16(v, t));
            vst1q_u16(o.as_mut_ptr().add(4).cast(), vzip2q_u16(v, t));
        }
        x += 8;
    }
    let rest = dst.iter_mut().zip(vis.iter().zip(tir)).skip(x);
    for (o, (&v, &t)) in rest {
        *o = lane_pair(v, t);
    }
}

/// `mid[x] = column_step(mid[x], enter[x], leave[x])` over the shortest of the three: per
/// 16-bit lane `d = enter − leave` (`|d| ≤ 255`), times (−1, 1), pairwise added into the
/// column sums (`sadalp`): `mid + (d_IR − d_VIS)`, four columns per step.
pub(super) fn column_steps(mid: &mut [i32], enter: &[i32], leave: &[i32]) {
    let n = mid.len().min(enter.len()).min(leave.len());
    let mut x = 0;
    // SAFETY: NEON register operations only.
    let signs = unsafe { vreinterpretq_s16_s32(vdupq_n_s32(0x0001_FFFF)) };
    while x + 4 <= n {
        let (Some(m), Some(e), Some(l)) = (
            mid.get_mut(x..x + 4).and_then(|s| <&mut [i32; 4]>::try_from(s).ok()),
            enter.get(x..x + 4).and_then(|s| <&[i32; 4]>::try_from(s).ok()),
            leave.get(x..x + 4).and_then(|s| <&[i32; 4]>::try_from(s).ok()),
        ) else {
            break;
        };
        // SAFETY: NEON; reads the 16 bytes of `e`, `l` and `m`, writes those of `m`.
        unsafe {
            let d = vsubq_s16(
                vreinterpretq_s16_s32(vld1q_s32(e.as_ptr())),
                vreinterpretq_s16_s32(vld1q_s32(l.as_ptr())),
            );
            vst1q_s32(m.as_mut_ptr(), vpadalq_s16(vld1q_s32(m.as_ptr()), vmulq_s16(d, signs)));
        }
        x += 4;
    }
    let rest = mid.iter_mut().zip(enter.iter().zip(leave)).skip(x);
    for (m, (&e, &l)) in rest {
        *m = column_step(*m, e, l, LANE_WEIGHTS);
    }
}

/// One chunk: the blocks of eight pixels in NEON, the rest by [`chunk_portable`] (which
/// continues the running sum).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn chunk_neon(
    ch: &FlightChunk<'_>,
    k: &Consts,
    sum: &mut i32,
    wide: &mut Wide,
    buf: &mut [[u32; 3]; CHUNK + 2],
    out: &mut [u8],
    zero: &mut bool,
    sat: &mut i32,
) {
    let n = out.len();
    // `c = 2·taps ≥ 2`, so the multiplier fits `sqdmulh`; otherwise the portable chunk.
    let blocks = if k.magic.m <= i32::MAX as u64 { n / 8 * 8 } else { 0 };
    let mut done = 0;
    if let Some(sd) = wide.sd.get_mut(..blocks + 2).filter(|_| blocks > 0) {
        // SAFETY: NEON is part of every AArch64 target this module is compiled for; every load
        // and store goes through a bounds-checked array reference.
        unsafe {
            scharr_columns_pair(ch.rows, Border::Replicate, ch.x0, sd, |o: &mut [u32; 2], s, d| *o = [s, d]);
            done = blocks_neon(ch, k, sum, sd, out, zero, sat, blocks);
        }
    }
    if done < n {
        let tail = FlightChunk {
            enter: ch.enter.get(done..).unwrap_or(&[]),
            leave: ch.leave.get(done..).unwrap_or(&[]),
            iv: ch.iv.get(done..).unwrap_or(&[]),
            ii: ch.ii.get(done..).unwrap_or(&[]),
            rows: ch.rows,
            x0: ch.x0 + done,
        };
        chunk_portable(&tail, k, sum, buf, out.get_mut(done..).unwrap_or(&mut []), zero, sat);
    }
}

/// The first `blocks` pixels (a multiple of 8) of the chunk, with the Scharr columns `sd`
/// (`blocks + 2`); returns the pixels done.
///
/// # Safety
/// NEON must be available (always on AArch64 with the `neon` feature).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn blocks_neon(
    ch: &FlightChunk<'_>,
    k: &Consts,
    sum: &mut i32,
    sd: &[[u32; 2]],
    out: &mut [u8],
    zero: &mut bool,
    sat: &mut i32,
    blocks: usize,
) -> usize {
    // SAFETY: NEON register operations only.
    let mut four = unsafe { Four::new(k, *sum) };
    // Every slice cut to the blocks' length once, so that the loop's bounds checks are its
    // condition (about ten instructions per step fewer on the A53).
    let blocks = blocks / 8 * 8;
    let (Some(enter), Some(leave), Some(iv), Some(ii), Some(sd), Some(out)) = (
        ch.enter.get(..blocks),
        ch.leave.get(..blocks),
        ch.iv.get(..blocks),
        ch.ii.get(..blocks),
        sd.get(..blocks + 2),
        out.get_mut(..blocks),
    ) else {
        return 0;
    };
    let mut i = 0;
    while i + 8 <= blocks {
        let (Some(e), Some(l), Some(cols), Some(iv), Some(ii), Some(o)) = (
            enter.get(i..i + 8).and_then(|s| <&[i32; 8]>::try_from(s).ok()),
            leave.get(i..i + 8).and_then(|s| <&[i32; 8]>::try_from(s).ok()),
            sd.get(i..i + 10).and_then(|s| <&[[u32; 2]; 10]>::try_from(s).ok()),
            iv.get(i..i + 8).and_then(|s| <&[u8; 8]>::try_from(s).ok()),
            ii.get(i..i + 8).and_then(|s| <&[u8; 8]>::try_from(s).ok()),
            out.get_mut(i..i + 8).and_then(|s| <&mut [u8; 8]>::try_from(s).ok()),
        ) else {
            break;
        };
        // SAFETY: the loads read within `e`, `l` (8 words), `cols` (10 pairs: 4 from offsets 0,
        // 1, 2, 4, 5, 6), `iv`, `ii` (8 bytes); the store writes the 8 bytes of `o`.
        unsafe {
            let (e, l, cols) = (e.as_ptr(), l.as_ptr(), cols.as_ptr().cast::<u32>());
            let (iv, ii) = (vmovl_u8(vld1_u8(iv.as_ptr())), vmovl_u8(vld1_u8(ii.as_ptr())));
            let d0 = vsubq_s32(vld1q_s32(e), vld1q_s32(l));
            let d1 = vsubq_s32(vld1q_s32(e.add(4)), vld1q_s32(l.add(4)));
            let lo = four.apply(d0, vmovl_u16(vget_low_u16(iv)), vmovl_u16(vget_low_u16(ii)), cols);
            let hi = four.apply(d1, vmovl_high_u16(iv), vmovl_high_u16(ii), cols.add(8));
            vst1_u8(o.as_mut_ptr(), vqmovn_u16(vcombine_u16(vqmovun_s32(lo), vqmovun_s32(hi))));
        }
        i += 8;
    }
    // SAFETY: NEON register operations only.
    unsafe {
        *sum = vgetq_lane_s32::<0>(four.running);
        *zero |= vmaxvq_u32(four.flat) != 0;
        *sat |= i32::from(vmaxvq_u32(vreinterpretq_u32_s32(four.sat)) != 0);
    }
    i
}

/// The constants and running values of four pixels' outputs.
struct Four {
    c: uint32x4_t,
    c2: uint32x4_t,
    taps: uint32x4_t,
    /// `m` of [`MagicC`] (below 2³¹ for `c ≥ 2`, see [`Four::new`]).
    magic: int32x4_t,
    /// `31 − s`: `ushl` by a negative count shifts right.
    magic_shift: int32x4_t,
    /// The running window sum in every lane.
    running: int32x4_t,
    /// Lanes all ones where a pixel had both weights 0.
    flat: uint32x4_t,
    /// The OR of `v >> 8` (non-zero: some output saturated).
    sat: int32x4_t,
}

impl Four {
    /// # Safety
    /// NEON must be available.
    #[inline(always)]
    unsafe fn new(k: &Consts, sum: i32) -> Self {
        // SAFETY: NEON register operations only.
        unsafe {
            Four {
                c: vdupq_n_u32(k.c.get()),
                c2: vdupq_n_u32(2 * k.c.get()),
                taps: vdupq_n_u32(k.taps),
                magic: vdupq_n_s32(k.magic.m as i32),
                magic_shift: vdupq_n_s32(31 - k.magic.s as i32),
                running: vdupq_n_s32(sum),
                flat: vdupq_n_u32(0),
                sat: vdupq_n_s32(0),
            }
        }
    }

    /// `⌊n/c⌋` of four lanes (`n < 2²⁸`; [`MagicC`]: `⌊n·m / 2³¹⌋` by `sqdmulh`, then the
    /// shift by `s − 31`).
    #[inline(always)]
    unsafe fn div_c(&self, n: uint32x4_t) -> uint32x4_t {
        // SAFETY: NEON register operations only.
        unsafe {
            let high = vqdmulhq_s32(vreinterpretq_s32_u32(n), self.magic);
            vshlq_u32(vreinterpretq_u32_s32(high), self.magic_shift)
        }
    }

    /// `v − 128` before the clamp of four pixels: `d` their window sums' steps (`enter −
    /// leave`), `iv`, `ii` their pixels, `cols` their Scharr columns (`[sm, df]` pairs from
    /// the column left of the first pixel: six pairs read).
    ///
    /// # Safety
    /// NEON must be available; `cols` must point to six `[u32; 2]` pairs.
    #[inline(always)]
    unsafe fn apply(&mut self, d: int32x4_t, iv: uint32x4_t, ii: uint32x4_t, cols: *const u32) -> int32x4_t {
        // SAFETY: NEON register operations, and loads of four pairs from pairs 0, 1 and 2 of
        // the six at `cols`.
        unsafe {
            // dd: the running sum before each pixel (the exclusive prefix sum of `d`).
            let p1 = vaddq_s32(d, vextq_s32::<3>(vdupq_n_s32(0), d));
            let p2 = vaddq_s32(p1, vextq_s32::<2>(vdupq_n_s32(0), p1));
            let dd = vreinterpretq_u32_s32(vaddq_s32(vsubq_s32(p2, d), self.running));
            self.running = vaddq_s32(self.running, vdupq_laneq_s32::<3>(p2));
            // The weight-free part, the three fields `packed` would pack: with `a = ⌊dd/c⌋`,
            // `q_VIS = I_VIS + a`, `q_IR = I_IR + 255 − a`, `r + taps = dd − c·a + taps`.
            let a = self.div_c(dd);
            let qv = vaddq_u32(iv, a);
            let qi = vsubq_u32(vaddq_u32(ii, vdupq_n_u32(255)), a);
            let rt = vmlsq_u32(vaddq_u32(dd, self.taps), a, self.c);
            // The weights (`scharr_l1_pair`): each 16-bit lane of a column word is a band.
            let left = vld2q_u32(cols);
            let mid = vld2q_u32(cols.add(2)).1;
            let right = vld2q_u32(cols.add(4));
            let gx = vsubq_u16(vreinterpretq_u16_u32(right.0), vreinterpretq_u16_u32(left.0));
            let gx = vabsq_s16(vreinterpretq_s16_u16(gx));
            let gy = vmlaq_n_u16(
                vmulq_n_u16(vreinterpretq_u16_u32(vaddq_u32(left.1, right.1)), 3),
                vreinterpretq_u16_u32(mid),
                10,
            );
            let gy = vabsq_s16(vsubq_s16(vreinterpretq_s16_u16(gy), vdupq_n_s16(4096)));
            let wts = vreinterpretq_u32_s16(vaddq_s16(gx, gy));
            // Both weights 0 (the word is 0): both become 1 (`flat` is all ones, −1).
            let flat = vceqzq_u32(wts);
            self.flat = vorrq_u32(self.flat, flat);
            let gv = vsubq_u32(vandq_u32(wts, vdupq_n_u32(0xFFFF)), flat);
            let gi = vsubq_u32(vshrq_n_u32::<16>(wts), flat);
            let sigma = vaddq_u32(gv, gi);
            // `output`: f = ⌊(w_VIS·rt + w_IR·(2c − rt) + ⌊taps·σ/2¹⁶⌋)/c⌋, then ⌊(…)/σ⌋ − 128.
            let num = vmlaq_u32(vmulq_u32(gv, rt), gi, vsubq_u32(self.c2, rt));
            let f = self.div_c(vaddq_u32(num, vshrq_n_u32::<16>(vmulq_u32(self.taps, sigma))));
            let x = vaddq_u32(vmlaq_u32(vmulq_u32(gv, qv), gi, qi), f);
            let v = vcvtq_u32_f32(vdivq_f32(vcvtq_f32_u32(x), vcvtq_f32_u32(sigma)));
            let v = vsubq_s32(vreinterpretq_s32_u32(v), vdupq_n_s32(128));
            self.sat = vorrq_s32(self.sat, vshrq_n_s32::<8>(v));
            v
        }
    }
}
