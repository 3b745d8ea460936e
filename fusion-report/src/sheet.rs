//! Contact sheets: tiles cropped to the target and laid out in rows.

use anyhow::{Result, anyhow};
use fusion_io::Gray;
use fusion_nostd::Filter;

/// The smallest square around the pixels brighter than `threshold` in any of `images` (all the
/// same size), grown by `margin` of its side and clamped to the frame: `(x0, y0, side)`. The
/// whole frame when nothing is bright.
pub fn target_square(images: &[&Gray<u8>], threshold: u8, margin: f64) -> (usize, usize, usize) {
    let Some(first) = images.first() else { return (0, 0, 0) };
    let (w, h) = (first.width, first.height);
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for img in images {
        for (i, &v) in img.data.iter().enumerate() {
            if v > threshold {
                let (x, y) = (i % w, i / w);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
            }
        }
    }
    if x1 <= x0 || y1 <= y0 {
        return (0, 0, w.min(h));
    }
    let side = ((x1 - x0).max(y1 - y0) as f64 * (1.0 + 2.0 * margin)).ceil() as usize;
    let side = side.clamp(1, w.min(h));
    let cx = (x0 + x1) / 2;
    let cy = (y0 + y1) / 2;
    let x = cx.saturating_sub(side / 2).min(w - side);
    let y = cy.saturating_sub(side / 2).min(h - side);
    (x, y, side)
}

/// The `side × side` square of `img` at `(x, y)`, rescaled (area down, cubic up) to `tile²`.
pub fn tile(img: &Gray<u8>, (x, y, side): (usize, usize, usize), tile: usize) -> Result<Gray<u8>> {
    let view = img.view()?;
    let crop = Gray {
        width: side,
        height: side,
        data: (y..y + side).flat_map(|r| view.row(r).iter().skip(x).take(side).copied()).collect(),
    };
    if crop.data.len() != side * side {
        return Err(anyhow!("crop {side}² at ({x}, {y}) leaves the {}x{} frame", img.width, img.height));
    }
    let filter = if side >= tile { Filter::Area } else { Filter::Cubic };
    fusion_io::source_on_grid(&crop, (tile, tile), filter)
}

/// A contact sheet: `rows` of equally sized tiles, separated by `gap` px of mid grey.
pub fn contact_sheet(rows: &[Vec<Gray<u8>>], gap: usize) -> Gray<u8> {
    let tile = rows.iter().flatten().map(|t| t.width.max(t.height)).max().unwrap_or(0);
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let w = cols * tile + (cols + 1) * gap;
    let h = rows.len() * tile + (rows.len() + 1) * gap;
    let mut sheet = Gray { width: w, height: h, data: vec![128; w * h] };
    for (r, row) in rows.iter().enumerate() {
        for (c, t) in row.iter().enumerate() {
            let (ox, oy) = (gap + c * (tile + gap), gap + r * (tile + gap));
            for y in 0..t.height {
                let src = &t.data[y * t.width..(y + 1) * t.width];
                let start = (oy + y) * w + ox;
                sheet.data[start..start + t.width].copy_from_slice(src);
            }
        }
    }
    sheet
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn target_square_covers_the_bright_pixels() {
        let mut img = Gray { width: 20, height: 10, data: vec![0u8; 200] };
        img.data[3 * 20 + 12] = 200;
        img.data[5 * 20 + 15] = 200;
        let (x, y, side) = target_square(&[&img], 10, 0.0);
        assert_eq!(side, 4, "columns 12..=15 (4) by rows 3..=5 (3)");
        assert!(x <= 12 && x + side >= 16 && y <= 3 && y + side >= 6, "({x}, {y}, {side})");
        // nothing bright: the largest square at the origin
        assert_eq!(
            target_square(&[&Gray { width: 20, height: 10, data: vec![0; 200] }], 10, 0.1),
            (0, 0, 10)
        );
    }

    #[test]
    fn contact_sheet_places_tiles_with_gaps() {
        let t = |v| Gray { width: 2, height: 2, data: vec![v; 4] };
        let sheet = contact_sheet(&[vec![t(10), t(20)], vec![t(30)]], 1);
        assert_eq!((sheet.width, sheet.height), (7, 7));
        assert_eq!(sheet.at(1, 1), 10);
        assert_eq!(sheet.at(4, 2), 20);
        assert_eq!(sheet.at(2, 4), 30);
        assert_eq!(sheet.at(0, 0), 128);
        assert_eq!(sheet.at(4, 4), 128, "missing tile stays grey");
    }
}
