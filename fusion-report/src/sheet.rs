//! Contact sheets: tiles cropped to the target and laid out in rows ([`contact_sheet`]), and
//! the same with the column and row names written on the image ([`labelled_sheet`]), so a
//! sheet explains itself without the text beside it. Text in `embedded-graphics`'s built-in
//! 10×20 monospace font (ASCII; no font file needed), white on the sheet's mid grey.

use anyhow::{Result, anyhow};
use embedded_graphics::Drawable;
use embedded_graphics::mono_font::MonoTextStyle;
use embedded_graphics::mono_font::ascii::FONT_10X20;
use embedded_graphics::pixelcolor::Gray8;
use embedded_graphics::prelude::{DrawTarget, GrayColor, OriginDimensions, Pixel, Point, Size};
use embedded_graphics::text::{Baseline, Text};
use fusion_io::Gray;
use fusion_nostd::Filter;

/// Grey level of the gaps and the label bands.
pub const BACKGROUND: u8 = 128;
/// Grey level of the labels.
const INK: u8 = 255;
/// Width and height of one character of the labels, px.
const CHAR: (usize, usize) = (10, 20);

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
    let mut sheet = Gray { width: w, height: h, data: vec![BACKGROUND; w * h] };
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

/// [`contact_sheet`] with `columns` written above the tile columns and `rows` left of the tile
/// rows (column names longer than a tile is wide are cut to fit, ending in `~`; non-ASCII
/// characters are drawn as `?`). Fewer names than
/// columns or rows leave the rest unnamed.
pub fn labelled_sheet(tiles: &[Vec<Gray<u8>>], gap: usize, columns: &[&str], rows: &[&str]) -> Gray<u8> {
    let body = contact_sheet(tiles, gap);
    let tile = tiles.iter().flatten().map(|t| t.width.max(t.height)).max().unwrap_or(0);
    let max_chars = (tile / CHAR.0).max(1);
    let ascii = |name: &str| -> String {
        name.chars().map(|c| if c.is_ascii() && !c.is_ascii_control() { c } else { '?' }).collect()
    };
    // Column names share a tile's width; row names get a band as wide as the longest.
    let fit = |name: &str| -> String {
        let text = ascii(name);
        if text.len() <= max_chars { text } else { format!("{}~", &text[..max_chars - 1]) }
    };
    let row_chars = rows.iter().map(|r| ascii(r).len()).max().unwrap_or(0);
    let left = if row_chars == 0 { 0 } else { row_chars * CHAR.0 + gap };
    let top = if columns.is_empty() { 0 } else { CHAR.1 + gap };
    let (w, h) = (body.width + left, body.height + top);
    let mut sheet = Gray { width: w, height: h, data: vec![BACKGROUND; w * h] };
    for y in 0..body.height {
        let dst = (y + top) * w + left;
        sheet.data[dst..dst + body.width].copy_from_slice(&body.data[y * body.width..(y + 1) * body.width]);
    }
    let mut canvas = Canvas(&mut sheet);
    let style = MonoTextStyle::new(&FONT_10X20, Gray8::new(INK));
    for (c, name) in columns.iter().enumerate() {
        let name = fit(name);
        let x = left + gap + c * (tile + gap) + (tile.saturating_sub(name.len() * CHAR.0)) / 2;
        draw(&mut canvas, &name, x, gap / 2, style);
    }
    for (r, name) in rows.iter().enumerate() {
        let y = top + gap + r * (tile + gap) + tile.saturating_sub(CHAR.1) / 2;
        draw(&mut canvas, &ascii(name), gap / 2, y, style);
    }
    sheet
}

fn draw(canvas: &mut Canvas<'_>, text: &str, x: usize, y: usize, style: MonoTextStyle<'_, Gray8>) {
    let at = Point::new(i32::try_from(x).unwrap_or(i32::MAX), i32::try_from(y).unwrap_or(i32::MAX));
    // Drawing into memory cannot fail (`Canvas::Error` is `Infallible`).
    let Ok(_) = Text::with_baseline(text, at, style, Baseline::Top).draw(canvas);
}

/// A sheet as an `embedded-graphics` target: pixels outside it are dropped.
struct Canvas<'a>(&'a mut Gray<u8>);

impl OriginDimensions for Canvas<'_> {
    fn size(&self) -> Size {
        Size::new(self.0.width as u32, self.0.height as u32)
    }
}

impl DrawTarget for Canvas<'_> {
    type Color = Gray8;
    type Error = core::convert::Infallible;

    fn draw_iter<I: IntoIterator<Item = Pixel<Gray8>>>(&mut self, pixels: I) -> Result<(), Self::Error> {
        let (w, h) = (self.0.width, self.0.height);
        for Pixel(p, colour) in pixels {
            if let (Ok(x), Ok(y)) = (usize::try_from(p.x), usize::try_from(p.y))
                && x < w
                && y < h
            {
                self.0.data[y * w + x] = colour.luma();
            }
        }
        Ok(())
    }
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

    #[test]
    fn labelled_sheet_writes_the_names_in_the_bands() {
        let t = |v| Gray { width: 40, height: 40, data: vec![v; 1600] };
        let plain = contact_sheet(&[vec![t(0), t(0)], vec![t(0), t(0)]], 4);
        let sheet =
            labelled_sheet(&[vec![t(0), t(0)], vec![t(0), t(0)]], 4, &["VIS", "TIR"], &["light", "ecl"]);
        // A band of one text line on top, one of five characters on the left.
        assert_eq!((sheet.width, sheet.height), (plain.width + 5 * 10 + 4, plain.height + 20 + 4));
        let (left, top) = (54, 24);
        // The tiles are where the plain sheet had them, untouched by the text.
        for y in 0..plain.height {
            assert_eq!(
                &sheet.data[(y + top) * sheet.width + left..][..plain.width],
                &plain.data[y * plain.width..][..plain.width]
            );
        }
        // Ink in the top band over each column and in the left band beside each row; none in the corner.
        let ink = |x0: usize, x1: usize, y0: usize, y1: usize| {
            (y0..y1)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| sheet.data[y * sheet.width + x] == INK)
                .count()
        };
        assert!(ink(left + 4, left + 44, 0, top) > 20, "VIS");
        assert!(ink(left + 48, left + 88, 0, top) > 20, "TIR");
        assert!(ink(0, left, top + 4, top + 44) > 20, "light");
        assert!(ink(0, left, top + 48, top + 88) > 20, "ecl");
        assert_eq!(ink(0, left, 0, top), 0, "the corner stays empty");
        // A name too long for its tile is cut: it stays within its column.
        let long = labelled_sheet(&[vec![t(0), t(0)]], 4, &["a very long column name", "b"], &[]);
        let stray = (0..20)
            .flat_map(|y| (44..48).map(move |x| (x, y)))
            .filter(|&(x, y)| long.data[y * long.width + x] == INK)
            .count();
        assert_eq!(stray, 0, "nothing drawn in the gap between the columns");
    }
}
