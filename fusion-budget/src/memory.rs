//! The image's static memory from the linker map: the regions and their use, as Markdown.

#[allow(unused_imports)]
use super::*;

pub(super) fn parse_size(s: &str) -> Option<u64> {
    let s = s.trim();
    let (num, mul) = if let Some(n) = s.strip_suffix(['K', 'k']) {
        (n, 1024)
    } else if let Some(n) = s.strip_suffix(['M', 'm']) {
        (n, 1024 * 1024)
    } else {
        (s, 1)
    };
    let v = if let Some(h) = num.strip_prefix("0x").or_else(|| num.strip_prefix("0X")) {
        u64::from_str_radix(h, 16).ok()?
    } else {
        num.parse().ok()?
    };
    Some(v * mul)
}

/// The `MEMORY { NAME : ORIGIN = …, LENGTH = … }` regions of a linker map.
pub fn memory_regions(map: &str) -> Vec<(String, u64, u64)> {
    let mut out = Vec::new();
    for line in map.lines() {
        let line = line.split("/*").next().unwrap_or("");
        let Some((name, rest)) = line.split_once(':') else { continue };
        let (mut origin, mut length) = (None, None);
        for part in rest.split(',') {
            if let Some((k, v)) = part.split_once('=') {
                match k.trim() {
                    "ORIGIN" | "org" | "o" => origin = parse_size(v),
                    "LENGTH" | "len" | "l" => length = parse_size(v),
                    _ => {}
                }
            }
        }
        if let (Some(o), Some(l)) = (origin, length) {
            out.push((name.trim().to_string(), o, l));
        }
    }
    out
}

pub(super) fn mib(bytes: u64) -> String {
    if bytes >= 1 << 20 {
        format!("{:.2} MiB", bytes as f64 / f64::from(1 << 20))
    } else if bytes >= 1024 {
        format!("{:.1} KiB", bytes as f64 / 1024.0)
    } else {
        format!("{bytes} B")
    }
}

/// Markdown memory report of the built images: per memory region of the target, the static
/// sections placed there; plus what each method needs at each grid according to the core.
pub fn memory_report(out: &Outcome) -> Result<String> {
    let mut s = String::new();
    s.push_str("| target | image | region | size | static use | of which | stack (measured) |\n");
    s.push_str("|---|---|---|---|---|---|---|\n");
    for (target, grid, path) in &out.images {
        let elf = Elf::read(path)?;
        let map = std::fs::read_to_string(target.linker_map())?;
        let stack = out.stacks.iter().find(|(t, g, _)| t == target && g == grid).map(|&(_, _, b)| b);
        for (name, origin, length) in memory_regions(&map) {
            let inside: Vec<_> =
                elf.alloc_sections().filter(|sec| sec.addr >= origin && sec.addr < origin + length).collect();
            let used: u64 = inside.iter().map(|sec| sec.size).sum();
            let mut parts: Vec<String> =
                inside.iter().map(|sec| format!("{} {}", sec.name, mib(sec.size))).collect();
            // `.data` also has a load copy in flash on Arm.
            if name == "FLASH" {
                for sec in elf.alloc_sections().filter(|x| x.name == ".data") {
                    parts.push(format!(".data load copy {}", mib(sec.size)));
                }
            }
            let stack_cell = match (name.as_str(), stack) {
                ("RAM", Some(b)) => mib(b),
                _ => String::new(),
            };
            let _ = writeln!(
                s,
                "| {target} | {}² | {name} | {} | {} ({:.1} %) | {} | {stack_cell} |",
                grid.side(),
                mib(length),
                mib(used),
                100.0 * used as f64 / length as f64,
                parts.join(", "),
            );
        }
    }
    s.push_str("\nWhat the core needs per method (`FuseConfig::scratch_pixels`: three `i32` planes + the `u8` band plane, plus the frames VIS in, TIR in, fused out):\n\n");
    s.push_str("| grid | method | scratch | frames | total |\n|---|---|---|---|---|\n");
    for grid in [Grid::G512, Grid::G1024] {
        for m in [MethodArg::Adf, MethodArg::Tsifsd, MethodArg::Ifevip, MethodArg::Adaptive] {
            let pipeline = FuseConfig {
                rescale: grid.policy().into(),
                method: method_for(m, VariantArg::Flight),
                ..Default::default()
            };
            let px = pipeline.scratch_pixels((1024, 1024), (512, 512))? as u64;
            let scratch = px * (3 * 4 + 1);
            let side = grid.side() as u64;
            let frames = 1024 * 1024 + 512 * 512 + side * side;
            let _ = writeln!(
                s,
                "| {side}² | {} | {} | {} | {} |",
                method_key(m),
                mib(scratch),
                mib(frames),
                mib(scratch + frames)
            );
        }
    }
    Ok(s)
}
