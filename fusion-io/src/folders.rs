//! Whole folders: files paired by name without extension, run in parallel with a progress bar
//! on a terminal (plain lines otherwise), every failure kept with its reason.

use anyhow::{Context, Result, bail};
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// The extensions a folder's images may have (case-insensitive): every format the readers take
/// and `fusion fuse --format` writes.
pub const IMAGE_EXTENSIONS: [&str; 7] = ["png", "jpg", "jpeg", "tif", "tiff", "pgm", "ppm"];

/// The images of one folder by stem; a stem held by two files is an error of that stem. Stems
/// are the file names' own bytes: a name that is not UTF-8 is paired like any other (shown with
/// U+FFFD where it cannot be printed).
fn images_by_stem(dir: &Path) -> Result<BTreeMap<OsString, Vec<PathBuf>>> {
    let mut map: BTreeMap<OsString, Vec<PathBuf>> = BTreeMap::new();
    for entry in std::fs::read_dir(dir).with_context(|| format!("cannot list {}", dir.display()))? {
        let path = entry.with_context(|| format!("cannot list {}", dir.display()))?.path();
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        if !path.is_file() || !ext.is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.as_str())) {
            continue;
        }
        if let Some(stem) = path.file_stem() {
            map.entry(stem.to_os_string()).or_default().push(path);
        }
    }
    Ok(map)
}

/// `stem.ext` in `dir`, from the stem's own bytes (an output named after its input, whatever
/// the input's name is made of).
pub fn output_path(dir: &Path, input: &Path, ext: &str) -> PathBuf {
    let mut name = input.file_stem().unwrap_or_default().to_os_string();
    name.push(".");
    name.push(ext);
    dir.join(name)
}

/// Stems with one file in each folder (in folder order), and the stems that cannot be paired
/// with the reason. `names` name the folders in messages (e.g. "visible", "thermal").
pub type Pairing = (Vec<(String, Vec<PathBuf>)>, Vec<(String, String)>);

/// Names in natural order: runs of digits compare by value (`frame_99` < `frame_100`), the
/// rest character by character; a sequence's frames come in time order whatever the padding.
pub fn natural_order(a: &str, b: &str) -> std::cmp::Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for i in 1..=bytes.len() {
            if i == bytes.len() || bytes[i].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..i]));
                start = i;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for ((da, sa), (db, sb)) in ca.iter().zip(&cb) {
        let ord = if *da && *db {
            let (ta, tb) = (sa.trim_start_matches('0'), sb.trim_start_matches('0'));
            ta.len().cmp(&tb.len()).then(ta.cmp(tb)).then(sa.len().cmp(&sb.len()))
        } else {
            sa.cmp(sb)
        };
        if ord != std::cmp::Ordering::Equal {
            return ord;
        }
    }
    ca.len().cmp(&cb.len())
}

/// Refuses an output folder that is one of the input folders (the outputs would land beside,
/// or over, the inputs).
pub fn check_output_folder(out: &Path, inputs: &[&Path]) -> Result<()> {
    if inputs.iter().any(|input| same_file(out, input)) {
        bail!("{} is an input folder: give the outputs a folder of their own", out.display());
    }
    Ok(())
}

/// Refuses an output file that is one of the input files (by any name: the same path, a
/// symbolic link to it, or a hard link), which the run would overwrite.
pub fn check_output_file(out: &Path, inputs: &[&Path]) -> Result<()> {
    if let Some(input) = inputs.iter().find(|input| same_file(out, input)) {
        bail!("{} is the input {}: give the output a name of its own", out.display(), input.display());
    }
    Ok(())
}

/// Whether two paths name one existing file or folder.
fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else { return false };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

/// Names with what each gave, and names with why each failed.
pub type Split<R> = (Vec<(String, R)>, Vec<(String, String)>);

/// The items that worked, and every failure (`unpaired` and the items' errors) sorted by name.
pub fn split_results<T, R>(
    items: &[(String, T)],
    results: Vec<Result<R>>,
    unpaired: Vec<(String, String)>,
) -> Split<R> {
    let mut ok = Vec::new();
    let mut failed = unpaired;
    for ((stem, _), r) in items.iter().zip(results) {
        match r {
            Ok(v) => ok.push((stem.clone(), v)),
            Err(e) => failed.push((stem.clone(), crate::console::one_line(&e))),
        }
    }
    failed.sort_by(|a, b| natural_order(&a.0, &b.0));
    (ok, failed)
}

/// Pairs the images of `dirs` by stem, in natural order ([`natural_order`]). An error when a
/// folder cannot be listed or no stem is in all of them.
pub fn pair_by_stem(dirs: &[(&Path, &str)]) -> Result<Pairing> {
    let maps = dirs.iter().map(|(d, _)| images_by_stem(d)).collect::<Result<Vec<_>>>()?;
    let mut stems: Vec<&OsString> = maps.iter().flat_map(|m| m.keys()).collect();
    stems.sort_by(|a, b| natural_order(&a.to_string_lossy(), &b.to_string_lossy()).then(a.cmp(b)));
    stems.dedup();
    let (mut pairs, mut unpaired) = (Vec::new(), Vec::new());
    for stem in stems {
        let shown = stem.to_string_lossy().into_owned();
        let mut files = Vec::new();
        let mut why = Vec::new();
        for (map, (dir, name)) in maps.iter().zip(dirs) {
            match map.get(stem).map(Vec::as_slice) {
                Some([one]) => files.push(one.clone()),
                Some(many) => {
                    let names: Vec<String> = many.iter().map(|p| p.display().to_string()).collect();
                    why.push(format!("two {name} images with this name ({})", names.join(", ")))
                }
                None => why.push(format!("no {name} image {shown}.* in {}", dir.display())),
            }
        }
        if why.is_empty() {
            pairs.push((shown, files));
        } else {
            unpaired.push((shown, why.join("; ")));
        }
    }
    if pairs.is_empty() {
        let names: Vec<String> = dirs.iter().map(|(d, _)| d.display().to_string()).collect();
        match unpaired.first() {
            Some((stem, why)) => bail!(
                "no complete set of images in {}: {stem}: {why}{}",
                names.join(" and "),
                if unpaired.len() > 1 {
                    format!(" (and {} more)", unpaired.len() - 1)
                } else {
                    String::new()
                }
            ),
            None => bail!("no images ({}) in {}", IMAGE_EXTENSIONS.join(", "), names.join(" and ")),
        }
    }
    Ok((pairs, unpaired))
}

/// `jobs` for [`run_all`]: one item after another, in order, on the calling thread.
pub const IN_ORDER: usize = usize::MAX;

/// Runs `work` on every item on `jobs` threads (0: every core), in any order — or, with
/// `jobs` = [`IN_ORDER`], one after another in the items' order on this thread (a sequence whose
/// frames depend on the one before); returns the results in the items' order. A progress bar
/// counts them on a terminal; otherwise one line per item goes to standard error (`verb [k/n]
/// stem: ok (what R shows)` / `failed: reason`), unless `--quiet`.
pub fn run_all<T: Send + Sync, R: Send + std::fmt::Display>(
    items: &[(String, T)],
    jobs: usize,
    verb: &str,
    work: impl Fn(&str, &T) -> Result<R> + Sync,
) -> Result<Vec<Result<R>>> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(if jobs == IN_ORDER { 1 } else { jobs })
        .build()
        .context("cannot start the worker threads")?;
    let terminal = std::io::stderr().is_terminal() && !crate::console::quiet();
    let bar = if terminal {
        let bar = indicatif::ProgressBar::new(items.len() as u64);
        if let Ok(style) = indicatif::ProgressStyle::with_template(
            "{msg} [{elapsed_precise}] {wide_bar} {pos}/{len} (eta {eta})",
        ) {
            bar.set_style(style);
        }
        bar.set_message(verb.to_string());
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let n = items.len();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let step = |(stem, item): &(String, T)| {
        let r = work(stem, item);
        let k = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
        if terminal {
            bar.inc(1);
        } else {
            match &r {
                Ok(v) => {
                    let v = v.to_string();
                    if v.is_empty() {
                        note!("{verb} [{k}/{n}] {stem}: ok")
                    } else {
                        note!("{verb} [{k}/{n}] {stem}: ok ({v})")
                    }
                }
                Err(e) => note!("{verb} [{k}/{n}] {stem}: failed: {}", crate::console::one_line(e)),
            }
        }
        r
    };
    let results = if jobs == IN_ORDER {
        items.iter().map(step).collect()
    } else {
        pool.install(|| items.par_iter().map(step).collect())
    };
    bar.finish_and_clear();
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order_puts_frames_in_time_order() {
        let mut v = vec!["frame_1000", "frame_101", "frame_99", "frame_100", "a", "frame_0099", "b2", "b10"];
        v.sort_by(|a, b| natural_order(a, b));
        assert_eq!(v, ["a", "b2", "b10", "frame_99", "frame_0099", "frame_100", "frame_101", "frame_1000"]);
    }
}
