//! `fusion fuse [options] VIS_DIR TIR_DIR OUT_DIR`: every pair of two folders, paired by name
//! without extension, fused in parallel into `OUT_DIR/NAME.png` (or `.tif`, `--format`).
//!
//! A pair that fails (unreadable, wrong size, no partner) is reported and the others go on; the
//! run ends with a summary on standard output and exit status 1 when any pair failed. Each
//! output is written atomically; the folder is created when missing.

use super::args::FuseArgs;
use super::pair::{agc_map, fuse_pair_quietly, thermal_chain};
use anyhow::{Context, Result, bail};
use fusion_io::folders::{pair_by_stem, run_all, split_results};
use fusion_io::{Gray, OutFormat, Picture};

/// A pair's two files and its thermal frame already through the AGC (`--agc-smoothing`), or
/// why that failed.
type PairFiles<'a> = (&'a [std::path::PathBuf], Option<Mapped>);

/// A thermal frame through the sequential front end and AGC, or why that failed.
type Mapped = Result<Gray<u8>, String>;

/// The thermal frames through the front end (`--nuc`, `--bad-pixels`, `--column-filter`) and
/// the AGC in natural name order (frame_99 before frame_100), one state of each carried from
/// frame to frame (`--agc-smoothing`): the one sequential step of a folder run. A frame that is
/// not 16-bit gets `None` (its pair reads it as it is, and refuses it when a front-end stage was
/// asked for); one that cannot be read or mapped gets the reason, and its pair fails with it.
fn sequential_thermal(
    args: &FuseArgs,
    pairs: &[(String, Vec<std::path::PathBuf>)],
) -> Result<Vec<Option<Mapped>>> {
    let mut agc = fusion_engine::agc::fresh();
    let mut chain = thermal_chain(args)?;
    let shutters = shutter_frames(args)?;
    Ok(pairs
        .iter()
        .map(|(stem, files)| {
            if let (Some(path), Some(c)) = (shutters.get(stem.as_str()), chain.as_mut()) {
                let levelled = match fusion_io::load_picture(path) {
                    Ok(Picture::Gray16(flat)) => c.shutter(&flat).map(|_| ()),
                    Ok(_) => Err(anyhow::anyhow!("{} is not 14/16-bit raw counts", path.display())),
                    Err(e) => Err(e),
                };
                if let Err(e) = levelled {
                    return Some(Err(format!(
                        "shutter frame {}: {}",
                        path.display(),
                        fusion_io::console::one_line(&e)
                    )));
                }
            }
            thermal_frame(args, &mut agc, chain.as_mut(), &files[1])
        })
        .collect())
}

/// The `--shutter-dir` frames by file name without extension.
fn shutter_frames(args: &FuseArgs) -> Result<std::collections::HashMap<String, std::path::PathBuf>> {
    let Some(dir) = &args.shutter_dir else { return Ok(Default::default()) };
    let mut out = std::collections::HashMap::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("--shutter-dir {}", dir.display()))? {
        let path = entry.with_context(|| format!("--shutter-dir {}", dir.display()))?.path();
        if let (true, Some(stem)) = (path.is_file(), path.file_stem()) {
            out.insert(stem.to_string_lossy().into_owned(), path.clone());
        }
    }
    Ok(out)
}

/// One thermal frame through the front end and the AGC (`None`: not 16-bit).
fn thermal_frame(
    args: &FuseArgs,
    agc: &mut fusion_nostd::Agc,
    chain: Option<&mut fusion_engine::thermal::ThermalChain>,
    path: &std::path::Path,
) -> Option<Mapped> {
    match fusion_io::load_picture(path) {
        Ok(Picture::Gray16(counts)) => {
            Some(agc_map(args, agc, chain, &counts, path).map_err(|e| fusion_io::console::one_line(&e)))
        }
        Ok(_) => None,
        Err(e) => Some(Err(format!("thermal image: {}", fusion_io::console::one_line(&e)))),
    }
}

/// Runs the folder form of `fusion fuse`.
pub fn run(args: &FuseArgs) -> Result<()> {
    if args.raw.is_some() {
        bail!("--raw names one file: it works with one pair, not with folders");
    }
    if args.output.exists() && !args.output.is_dir() {
        bail!("{} is not a folder: the pairs of two folders go into a folder", args.output.display());
    }
    fusion_io::folders::check_output_folder(&args.output, &[&args.vis, &args.tir])?;
    let (pairs, unpaired) = pair_by_stem(&[(&args.vis, "visible"), (&args.tir, "thermal")])?;
    // Removed again if no pair gets through (and on an interrupt while still empty).
    let _folder = fusion_io::output::create_folder(&args.output)?;
    let ext = args.format.unwrap_or(OutFormat::Png).extension();
    let jobs = args.jobs.unwrap_or(0);
    let front_end = args.nuc.is_some() || args.bad_pixels.is_some() || args.column_filter.is_some();
    if let Some(d) = &args.shutter_dir
        && !d.is_dir()
    {
        bail!("--shutter-dir {} is not a folder", d.display());
    }
    let mapped = if args.agc_smoothing.is_some_and(|k| k > 0) || front_end {
        sequential_thermal(args, &pairs)?
    } else {
        vec![None; pairs.len()]
    };
    let items: Vec<(String, PairFiles)> =
        pairs.iter().zip(mapped).map(|((stem, files), m)| (stem.clone(), (files.as_slice(), m))).collect();
    // --sequence-mode: one sequence, the pairs in name order on this thread.
    let seq =
        if args.sequence_mode { super::pair::sequence_fuser(args).map(std::sync::Mutex::new) } else { None };
    let jobs = if seq.is_some() { fusion_io::folders::IN_ORDER } else { jobs };
    let results = run_all(&items, jobs, "fuse", |_, (files, mapped)| {
        let out = fusion_io::folders::output_path(&args.output, &files[0], ext);
        let mapped = match mapped {
            Some(Err(why)) => bail!("{why}"),
            Some(Ok(g)) => Some(g.clone()),
            None => None,
        };
        fuse_pair_quietly(args, &files[0], &files[1], mapped, &out, seq.as_ref())
    })?;
    let (done, failed) = split_results(&items, results, unpaired);
    let fused = done.len();
    let total = fused + failed.len();
    outln!("fused {fused} of {total} pairs into {}", args.output.display())?;
    for (stem, why) in &failed {
        outln!("failed {stem}: {why}")?;
    }
    if !failed.is_empty() {
        bail!("{} of {total} pairs failed (listed above)", failed.len());
    }
    Ok(())
}
