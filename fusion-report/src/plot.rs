//! Charts for the reports, drawn with `plotters`: PNG when a TrueType font is found on the
//! machine (text needs one; Debian's `fonts-dejavu-core` is the usual source), SVG otherwise
//! (the viewer draws SVG text itself).

use anyhow::{Result, anyhow};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// One named line or point set.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// `(x, y)` points in drawing order.
    pub points: Vec<(f64, f64)>,
}

/// Renames every series whose points are, bit for bit, an earlier one's to
/// `"<name> (= <earlier>, drawn over it)"`: a line drawn exactly over another hides it, and the
/// legend says so.
pub fn name_identical(series: &mut [Series]) {
    let bits = |s: &Series| s.points.iter().map(|&(x, y)| (x.to_bits(), y.to_bits())).collect::<Vec<_>>();
    for i in 1..series.len() {
        let here = bits(&series[i]);
        if let Some(same) = series[..i].iter().find(|s| bits(s) == here).map(|s| s.name.clone()) {
            series[i].name = format!("{} (= {same}, drawn over it)", series[i].name);
        }
    }
}

/// How a chart draws its series.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// Lines with a marker at every point (per-frame curves).
    Lines,
    /// Markers only, x on a log axis (time against error).
    PointsLogX,
    /// Markers only, linear axes (per-frame values with gaps: no line bridges a missing frame).
    Points,
    /// Lines without markers, y on a log axis (errors over a sequence spanning decades; a
    /// missing or non-positive value breaks the line).
    LinesLogY,
}

/// Axis titles and the chart title.
#[derive(Debug, Clone, Copy)]
pub struct Labels<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// x-axis title.
    pub x: &'a str,
    /// y-axis title.
    pub y: &'a str,
}

const FONT_PATHS: [&str; 3] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// Registers a system TrueType font as `sans-serif` once; whether one was found.
fn font_available() -> bool {
    static FOUND: OnceLock<bool> = OnceLock::new();
    *FOUND.get_or_init(|| {
        FONT_PATHS.iter().any(|p| match std::fs::read(p) {
            Ok(bytes) => {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok()
            }
            Err(_) => false,
        })
    })
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

/// Draws `series` into `stem.png` (or `stem.svg` without a font); returns the path written.
pub fn chart(stem: &Path, labels: Labels<'_>, series: &[Series], style: Style) -> Result<PathBuf> {
    chart_shaded(stem, labels, series, style, &[])
}

/// [`chart`] with grey bands behind the series over the x ranges `shaded` (e.g. an eclipse).
pub fn chart_shaded(
    stem: &Path,
    labels: Labels<'_>,
    series: &[Series],
    style: Style,
    shaded: &[(f64, f64)],
) -> Result<PathBuf> {
    chart_bounded(stem, labels, series, &[], style, shaded)
}

/// [`chart_shaded`] with a bound per series (e.g. a filter's 3σ): `bounds[k]`, when present,
/// is drawn as a thin line in series `k`'s colour, without a legend entry.
pub fn chart_bounded(
    stem: &Path,
    labels: Labels<'_>,
    series: &[Series],
    bounds: &[Series],
    style: Style,
    shaded: &[(f64, f64)],
) -> Result<PathBuf> {
    // Drawn in memory, then written through the one write path (fusion_io::write_atomic).
    const SIZE: (u32, u32) = (900, 560);
    if font_available() {
        let path = stem.with_extension("png");
        let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
        draw(
            BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area(),
            labels,
            series,
            bounds,
            style,
            shaded,
        )?;
        fusion_io::write_atomic(&path, |w| {
            fusion_io::encode_png(w, SIZE.0 as usize, SIZE.1 as usize, image::ExtendedColorType::Rgb8, &rgb)
        })?;
        Ok(path)
    } else {
        let path = stem.with_extension("svg");
        let mut svg = String::new();
        draw(
            SVGBackend::with_string(&mut svg, SIZE).into_drawing_area(),
            labels,
            series,
            bounds,
            style,
            shaded,
        )?;
        fusion_io::write_bytes(&path, svg.as_bytes())?;
        Ok(path)
    }
}

fn bounds(series: &[Series], log_x: bool, log_y: bool) -> ((f64, f64), (f64, f64)) {
    let pts = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|p| p.0.is_finite() && p.1.is_finite() && (!log_y || p.1 > 0.0));
    let (mut x0, mut x1, mut y0, mut y1) =
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in pts {
        if log_x && x <= 0.0 {
            continue;
        }
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if !x0.is_finite() {
        return ((1.0, 10.0), (0.0, 1.0));
    }
    let pad = |lo: f64, hi: f64| {
        let d = if hi > lo { 0.05 * (hi - lo) } else { 0.5 * lo.abs().max(1.0) };
        (lo - d, hi + d)
    };
    let x = if log_x { (x0 / 1.5, x1 * 1.5) } else { pad(x0, x1) };
    let y = if log_y { (y0 / 1.5, y1 * 1.5) } else { pad(y0, y1) };
    (x, y)
}

fn draw<B: DrawingBackend>(
    root: DrawingArea<B, plotters::coord::Shift>,
    labels: Labels<'_>,
    series: &[Series],
    bound_lines: &[Series],
    style: Style,
    shaded: &[(f64, f64)],
) -> Result<()>
where
    B::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<B::ErrorType>| anyhow!("plot: {e:?}");
    root.fill(&WHITE).map_err(err)?;
    let log_x = style == Style::PointsLogX;
    let log_y = style == Style::LinesLogY;
    let all: Vec<Series> = series.iter().chain(bound_lines).cloned().collect();
    let ((x0, x1), (y0, y1)) = bounds(&all, log_x, log_y);
    let mut builder = ChartBuilder::on(&root);
    builder.caption(labels.title, ("sans-serif", 22)).margin(12).x_label_area_size(45).y_label_area_size(70);
    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart.configure_mesh().x_desc(labels.x).y_desc(labels.y).draw().map_err(err)?;
            let grey = RGBColor(200, 200, 200).mix(0.5).filled();
            chart
                .draw_series(shaded.iter().map(|&(a, b)| Rectangle::new([(a, y0), (b, y1)], grey)))
                .map_err(err)?;
            for (k, b) in bound_lines.iter().enumerate() {
                let colour = COLOURS[k % COLOURS.len()];
                for run in runs(&b.points, log_y) {
                    chart.draw_series(LineSeries::new(run, colour.mix(0.6).stroke_width(1))).map_err(err)?;
                }
            }
            for (k, s) in series.iter().enumerate() {
                let colour = COLOURS[k % COLOURS.len()];
                let pts: Vec<(f64, f64)> =
                    s.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
                let anno = if style == Style::LinesLogY {
                    let mut last = None;
                    for run in runs(&s.points, true) {
                        last = Some(
                            chart.draw_series(LineSeries::new(run, colour.stroke_width(2))).map_err(err)?,
                        );
                    }
                    match last {
                        Some(a) => a,
                        None => {
                            chart.draw_series(std::iter::empty::<Circle<(f64, f64), i32>>()).map_err(err)?
                        }
                    }
                } else if style == Style::Lines {
                    chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2))).map_err(err)?;
                    chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(err)?
                } else {
                    let size = if style == Style::Points { 3 } else { 6 };
                    chart
                        .draw_series(pts.iter().map(|&p| Circle::new(p, size, colour.filled())))
                        .map_err(err)?
                };
                anno.label(s.name.clone())
                    .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], colour.filled()));
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(err)?;
        }};
    }
    if log_x {
        body!(builder.build_cartesian_2d((x0..x1).log_scale(), y0..y1).map_err(err)?);
    } else if log_y {
        body!(builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale()).map_err(err)?);
    } else {
        body!(builder.build_cartesian_2d(x0..x1, y0..y1).map_err(err)?);
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The unbroken runs of a point list: a non-finite value (or a non-positive one on a log axis)
/// ends a run.
fn runs(points: &[(f64, f64)], log_y: bool) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![Vec::new()];
    for &(x, y) in points {
        if x.is_finite() && y.is_finite() && (!log_y || y > 0.0) {
            if let Some(r) = out.last_mut() {
                r.push((x, y));
            }
        } else if out.last().is_some_and(|r| !r.is_empty()) {
            out.push(Vec::new());
        }
    }
    out.retain(|r| !r.is_empty());
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_chart_file() {
        let dir = tempfile::tempdir().unwrap();
        let s = vec![
            Series { name: "a".into(), points: vec![(0.0, 1.0), (1.0, 2.0), (2.0, f64::NAN)] },
            Series { name: "b".into(), points: vec![(0.0, 3.0), (1.0, 0.5)] },
        ];
        let labels = Labels { title: "t", x: "x", y: "y" };
        let p = chart(&dir.path().join("c"), labels, &s, Style::Lines).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        assert!(bytes.len() > 1000, "a real image, {} bytes", bytes.len());
        let p = chart(&dir.path().join("d"), labels, &s, Style::PointsLogX).unwrap();
        assert!(p.exists());
        let p = chart_bounded(&dir.path().join("e"), labels, &s, &s[1..], Style::LinesLogY, &[(0.5, 1.0)])
            .unwrap();
        assert!(p.exists());
        assert_eq!(runs(&[(0.0, 1.0), (1.0, f64::NAN), (2.0, 2.0), (3.0, 0.0), (4.0, 1.0)], true).len(), 3);
    }

    #[test]
    fn identical_lines_are_named_in_the_legend() {
        let line = |name: &str, y: f64| Series { name: name.into(), points: vec![(0.0, 1.0), (1.0, y)] };
        let mut s =
            vec![line("a", 2.0), line("b", 3.0), line("c", 2.0), line("d", f64::NAN), line("e", f64::NAN)];
        name_identical(&mut s);
        let names: Vec<&str> = s.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["a", "b", "c (= a, drawn over it)", "d", "e (= d, drawn over it)"]);
    }

    #[test]
    fn bounds_pad_and_skip_non_finite() {
        let s = [Series { name: String::new(), points: vec![(1.0, 2.0), (3.0, 4.0), (f64::NAN, 9.0)] }];
        let ((x0, x1), (y0, y1)) = bounds(&s, false, false);
        assert!(x0 < 1.0 && x1 > 3.0 && y0 < 2.0 && y1 > 4.0 && y1 < 9.0);
    }
}
