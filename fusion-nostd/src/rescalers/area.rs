//! Area 2× kernels, bit-exact with OpenCV `INTER_AREA`.
//!
//! * Down (2W×2H → W×H): the mean of each 2×2 block, `(a + b + c + d + 2) >> 2` for integer
//!   samples (round half **up**, unlike cubic), `((a + b) + (c + d)) · 0.25` for `f32`.
//! * Up (W×H → 2W×2H): pixel replication, `out[y][x] = src[y/2][x/2]`, for every type.

use crate::{FrameMut, FrameRef};

crate::cpu::dispatch! {
    /// 2×2 block mean of u8 rows, rounded half up.
    pub(crate) fn down2_u8(src: FrameRef<'_, u8>, dst: FrameMut<'_, u8>) => down2_u8_kernel
}

/// Four 2×2 block means at once in a `u64` (SWAR): `a` and `b` hold 8 pixels of two rows.
///
/// Each 16-bit lane gets one block sum (≤ 1020 + 2, no carry between lanes); after the shift
/// by 2 the lane's low byte is the mean and the bits a neighbour lane shifted in are masked.
#[inline(always)]
fn block_means_x4(a: u64, b: u64) -> u32 {
    const LO: u64 = 0x00FF_00FF_00FF_00FF;
    let sums = (a & LO) + ((a >> 8) & LO) + (b & LO) + ((b >> 8) & LO) + 0x0002_0002_0002_0002;
    let v = (sums >> 2) & LO;
    let v = (v | (v >> 8)) & 0x0000_FFFF_0000_FFFF;
    ((v | (v >> 16)) & 0xFFFF_FFFF) as u32
}

#[inline(always)]
fn down2_u8_kernel(src: FrameRef<'_, u8>, mut dst: FrameMut<'_, u8>) {
    let mut src_rows = src.rows();
    for out in dst.rows_mut() {
        let (Some(r0), Some(r1)) = (src_rows.next(), src_rows.next()) else {
            return;
        };
        let quads = out.chunks_exact_mut(4).zip(r0.chunks_exact(8).zip(r1.chunks_exact(8)));
        for (o, (a, b)) in quads {
            if let (Ok(o), Ok(a), Ok(b)) =
                (<&mut [u8; 4]>::try_from(o), <[u8; 8]>::try_from(a), <[u8; 8]>::try_from(b))
            {
                *o = block_means_x4(u64::from_le_bytes(a), u64::from_le_bytes(b)).to_le_bytes();
            }
        }
        // The last `width % 4` outputs, one at a time.
        let done = out.len() / 4 * 4;
        let tail = out.get_mut(done..).unwrap_or(&mut []);
        let p0 = r0.get(2 * done..).unwrap_or(&[]).chunks_exact(2);
        let p1 = r1.get(2 * done..).unwrap_or(&[]).chunks_exact(2);
        for (o, (ab, cd)) in tail.iter_mut().zip(p0.zip(p1)) {
            if let ([a, b], [c, d]) = (ab, cd) {
                let sum = u16::from(*a) + u16::from(*b) + u16::from(*c) + u16::from(*d);
                *o = ((sum + 2) >> 2) as u8;
            }
        }
    }
}

/// 2×2 block mean of u16 rows, rounded half up.
pub(crate) fn down2_u16(src: FrameRef<'_, u16>, mut dst: FrameMut<'_, u16>) {
    let mut src_rows = src.rows();
    for out in dst.rows_mut() {
        let (Some(r0), Some(r1)) = (src_rows.next(), src_rows.next()) else {
            return;
        };
        for (o, (ab, cd)) in out.iter_mut().zip(r0.chunks_exact(2).zip(r1.chunks_exact(2))) {
            if let ([a, b], [c, d]) = (ab, cd) {
                let sum = u32::from(*a) + u32::from(*b) + u32::from(*c) + u32::from(*d);
                *o = ((sum + 2) >> 2) as u16;
            }
        }
    }
}

/// 2×2 block mean of f32 rows in OpenCV's order.
pub(crate) fn down2_f32(src: FrameRef<'_, f32>, mut dst: FrameMut<'_, f32>) {
    let mut src_rows = src.rows();
    for out in dst.rows_mut() {
        let (Some(r0), Some(r1)) = (src_rows.next(), src_rows.next()) else {
            return;
        };
        for (o, (ab, cd)) in out.iter_mut().zip(r0.chunks_exact(2).zip(r1.chunks_exact(2))) {
            if let ([a, b], [c, d]) = (ab, cd) {
                *o = ((a + b) + (c + d)) * 0.25;
            }
        }
    }
}

/// Pixel replication, W×H → 2W×2H.
pub(crate) fn up2<T: Copy>(src: FrameRef<'_, T>, mut dst: FrameMut<'_, T>) {
    for (y, out) in dst.rows_mut().enumerate() {
        let row = src.row(y / 2);
        for (pair, v) in out.chunks_exact_mut(2).zip(row) {
            pair.fill(*v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swar_block_means_match_the_scalar_rule() {
        let cases: [[u8; 16]; 4] = [
            [0; 16],
            [255; 16],
            [1, 1, 1, 2, 0, 3, 255, 254, 255, 255, 1, 0, 0, 0, 253, 255],
            [7, 9, 200, 13, 0, 255, 128, 127, 5, 6, 100, 11, 255, 0, 127, 128],
        ];
        for c in cases {
            let (a, b) = c.split_at(8);
            let mut a8 = [0u8; 8];
            let mut b8 = [0u8; 8];
            a8.copy_from_slice(a);
            b8.copy_from_slice(b);
            let got = block_means_x4(u64::from_le_bytes(a8), u64::from_le_bytes(b8)).to_le_bytes();
            for k in 0..4 {
                let sum = u16::from(a8[2 * k])
                    + u16::from(a8[2 * k + 1])
                    + u16::from(b8[2 * k])
                    + u16::from(b8[2 * k + 1]);
                assert_eq!(got[k], ((sum + 2) >> 2) as u8, "{c:?} lane {k}");
            }
        }
    }
}
