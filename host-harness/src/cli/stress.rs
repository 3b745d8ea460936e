//! `fusion stress`: every method and variant, core and f64 reference, over adversarial frames
//! (the study itself: `fusion_engine::stress`).

use anyhow::{Result, bail};
use clap::Args;
use fusion_engine::stress::{Row, cases, full_table, geometries, methods, run_all, summary_table};
use fusion_io::{note, outln};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Arguments of `fusion stress`.
#[derive(Debug, Args)]
pub struct StressArgs {
    /// Small frames only (for CI: 24², 17×11 and VIS 34×22 / TIR 17×11), and IFEVIP on a 128²
    /// quadtree grid instead of 512² (the f64 reference's 32×32 erosion of a 512² grid dominates
    /// the run time otherwise).
    #[arg(long)]
    pub quick: bool,
    /// Also write the full table (every case, geometry and method) as Markdown to this file.
    #[arg(long, value_name = "FILE.md")]
    pub out: Option<PathBuf>,
}

/// Runs `fusion stress`.
pub fn run(args: &StressArgs) -> Result<()> {
    let t = std::time::Instant::now();
    let rows = run_all(args.quick);
    let full = full_table(&rows);
    outln!("{}", summary_table(&rows, args.quick))?;
    let failures: Vec<&Row> = rows.iter().filter(|r| r.failure.is_some()).collect();
    let nan_rows = rows.iter().filter(|r| r.ref_nan > 0).count();
    outln!(
        "{} runs ({} cases × {} geometries × {} methods), {} with NaN in the f64 reference, {} deterministic, \
         {} failures, {:.1} s",
        rows.len(),
        cases().len(),
        geometries(args.quick).len(),
        methods(args.quick).len(),
        nan_rows,
        rows.iter().filter(|r| r.deterministic).count(),
        failures.len(),
        t.elapsed().as_secs_f64()
    )?;
    if let Some(path) = &args.out {
        let mut doc = String::from("# fusion stress\n\nCases:\n\n");
        for c in cases() {
            let _ = writeln!(doc, "* `{}`: {}", c.name, c.what);
        }
        let _ = write!(
            doc,
            "\n## Summary (max error over the geometries)\n\n{}",
            summary_table(&rows, args.quick)
        );
        let _ = write!(doc, "\n## Every run\n\n{full}");
        fusion_io::write_bytes(path, doc.as_bytes())?;
    }
    for r in &failures {
        note!("FAIL {} {} {}: {}", r.case, r.geometry, r.method, r.failure.as_deref().unwrap_or(""));
    }
    if !failures.is_empty() {
        bail!("{} of {} stress runs failed", failures.len(), rows.len());
    }
    Ok(())
}
