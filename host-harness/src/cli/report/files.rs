//! The report's CSV files (one per table) and charts.

#[allow(unused_imports)]
use super::*;

/// One CSV with every per-frame value: `table,row,column,frame,value`.
pub(super) fn write_csvs(cells: &Cells, out: &Path) -> Result<()> {
    let mut per_frame = String::from("table,row,column,frame,value\n");
    let mut means = String::from("table,row,column,mean,median,frames\n");
    for ((t, r, c), v) in &cells.0 {
        for (i, x) in v.iter().enumerate() {
            let _ = writeln!(per_frame, "{t},{r},{c},{i},{x}");
        }
        let _ = writeln!(means, "{t},{r},{c},{},{},{}", mean_of(v), median_of(v), v.len());
    }
    let mut tables = fusion_io::Batch::default();
    tables.add_bytes(&out.join("per_frame.csv"), per_frame.as_bytes())?;
    tables.add_bytes(&out.join("tables.csv"), means.as_bytes())?;
    tables.commit()?;
    Ok(())
}

/// Per-frame metric curves (as the study's figures 10 and 12): for each illumination, the
/// 1:2 metrics with TIR upscaled and the noise PSNR_S, one line per method (core and host;
/// DRIF at different resolutions).
pub(super) fn write_charts(
    cells: &Cells,
    methods: &[NamedMethod],
    frames: usize,
    out: &Path,
) -> Result<Vec<PathBuf>> {
    let mut written = Vec::new();
    for (ill, illum) in ILLUMINATIONS {
        for (table, col, what) in [
            (Table::T4(illum), Col::Ag, "AG, TIR upscaled"),
            (Table::T4(illum), Col::Mi, "MI, TIR upscaled"),
            (Table::T4(illum), Col::Fmi, "FMI, TIR upscaled"),
            (Table::T4(illum), Col::Ssim, "SSIM, TIR upscaled"),
            (Table::T6(illum), Col::PsnrS, "PSNR_S (noisy vs noiseless fusion), TIR upscaled"),
        ] {
            let series: Vec<Series> = row_names(methods)
                .into_iter()
                .map(|name| {
                    let row = if matches!(table, Table::T6(_)) { tir_up_row(name) } else { name.to_string() };
                    let v = cells.values(table, &row, col);
                    Series {
                        name: name.into(),
                        points: v.iter().enumerate().map(|(i, &y)| (i as f64, y)).collect(),
                    }
                })
                .collect();
            let title = format!("{what}, {ill}, per frame ({frames} frames)");
            let stem = out.join(format!("frames_{}_{ill}", col.name().to_lowercase()));
            written.push(chart(
                &stem,
                Labels { title: &title, x: "frame", y: col.name() },
                &series,
                Style::Lines,
            )?);
        }
    }
    Ok(written)
}
