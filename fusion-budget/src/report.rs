//! The budget report (`fw/target/budget/report.md`): every table of a run as Markdown.

#[allow(unused_imports)]
use super::*;

/// Markdown tables of the measurements, the budget check and the estimates.
pub fn report(out: &Outcome, budgets: &Table, chk: &Check) -> String {
    let mut s = String::new();
    let mut groups: Vec<(Target, Grid)> = out.measured.iter().map(|m| (m.target, m.grid)).collect();
    groups.dedup();
    for (target, grid) in groups {
        let overhead = out.overheads.iter().find(|(t, g, _)| *t == target && *g == grid).map_or(0, |o| o.2);
        let _ = writeln!(
            s,
            "\n### {} ({target}), {}² grid — {}\n",
            target.core(),
            grid.side(),
            match grid {
                Grid::G512 => "VIS 1024² area-downscaled, fused with TIR 512²",
                Grid::G1024 => "TIR 512² bicubic-upscaled, fused with VIS 1024²",
            }
        );
        s.push_str("| method | stage | instructions | instr/px | budget | |\n|---|---|---:|---:|---:|---|\n");
        for m in out.measured.iter().filter(|m| m.target == target && m.grid == grid) {
            for st in &m.stages {
                let b = budgets.get(&m.key(st.key));
                let verdict = match b {
                    None => "no budget",
                    Some(b) if m.per_px(st) > b => "**over**",
                    Some(_) => "ok",
                };
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.2} | {} | {verdict} |",
                    method_key(m.method),
                    st.key,
                    st.count,
                    m.per_px(st),
                    b.map_or_else(|| "—".to_string(), |b| format!("{b}")),
                );
            }
        }
        let _ = writeln!(
            s,
            "\nEvery region includes the marker overhead of {overhead} instructions (an empty region)."
        );
    }
    if !out.agc.is_empty() {
        s.push_str(
            "\n### Thermal band: the AGC alone (`fusion_nostd::agc_frame`) and the front end's stages (`fusion_nostd::thermal`, then the linear AGC), on the budget pair's TIR as 14-bit counts; its registration onto the visible grid (`fusion_nostd::registration`, per visible pixel)\n\n\
             | target | stage | TIR | instructions | instr/px | budget | time at the target's clock (CPI range) | |\n\
             |---|---|---|---:|---:|---:|---|---|\n",
        );
        for a in &out.agc {
            let b = budgets.get(&a.key());
            let verdict = match b {
                None => "no budget",
                Some(b) if a.per_px() > b => "**over**",
                Some(_) => "ok",
            };
            let (lo, hi) = a.target.cpi();
            let clock = a.target.clock_hz();
            let ms = |cpi: f64| format!("{:.2}", a.count as f64 * cpi / clock * 1e3);
            let _ = writeln!(
                s,
                "| {} | {} {} | {}x{} | {} | {:.2} | {} | {}–{} ms | {verdict} |",
                a.target,
                a.stage.table(),
                a.stage.name(),
                a.size.0,
                a.size.1,
                a.count,
                a.per_px(),
                b.map_or_else(|| "—".to_string(), |b| format!("{b}")),
                ms(lo),
                ms(hi),
            );
        }
    }
    s.push_str(
        "\n### Whole pipeline: estimates at each target's stated clock and CPI range\n\n\
         QEMU has no timing model: cycles = instructions × the stated CPI range, time at the stated \
         clock (Cortex-M7 and RV32 400 MHz, Cortex-A53 1.2 GHz).\n\n",
    );
    s.push_str("| target | grid | method | instr/px | instructions | CPI | cycles | clock | time/frame | frames/s | goal (instr/px) |\n");
    s.push_str("|---|---|---|---:|---:|---|---:|---:|---:|---:|---|\n");
    for m in &out.measured {
        let n = m.pipeline() as f64;
        let (lo, hi) = m.target.cpi();
        let clock = m.target.clock_hz();
        let per_px = n / m.pixels() as f64;
        let goal = budgets.get(&format!("goal.{}.{}.{}", m.target, m.grid.side(), method_key(m.method)));
        let goal_cell = match goal {
            None => "—".to_string(),
            Some(g) if per_px <= g => format!("{g}: met"),
            Some(g) => format!("{g}: **not met** ({:.1}×)", per_px / g),
        };
        let range =
            |f: &dyn Fn(f64) -> String| if lo == hi { f(lo) } else { format!("{}–{}", f(lo), f(hi)) };
        let _ = writeln!(
            s,
            "| {} | {}² | {} | {:.1} | {} | {} | {} | {:.1} GHz | {} | {} | {goal_cell} |",
            m.target,
            m.grid.side(),
            method_key(m.method),
            per_px,
            m.pipeline(),
            range(&|c| format!("{c:.1}")),
            range(&|c| format!("{:.0} M", n * c / 1e6)),
            clock / 1e9,
            range(&|c| format!("{:.0} ms", n * c / clock * 1e3)),
            // Frame rate falls as CPI rises: high CPI first.
            if lo == hi {
                format!("{:.2}", clock / (n * lo))
            } else {
                format!("{:.2}–{:.2}", clock / (n * hi), clock / (n * lo))
            },
        );
    }
    if !out.strips.is_empty() {
        s.push_str(&strip_table(out));
    }
    if !out.exact.is_empty() {
        s.push_str("\n### Bit-exactness against the host\n\n| runs | identical |\n|---|---|\n");
        for (what, n, same) in &out.exact {
            let _ = writeln!(s, "| {what} | {same}/{n} |");
        }
    }
    for t in &out.fault_exit {
        let _ = writeln!(
            s,
            "\n{t}: a deliberate fault (undefined instruction) was reported and ended QEMU with status 1."
        );
    }
    let _ = writeln!(
        s,
        "\nBudget check: {} entries, {} over, {} without a budget, {} more than 10 % under budget.",
        chk.checked,
        chk.over.len(),
        chk.missing.len(),
        chk.slack.len()
    );
    s
}

/// The strip runs next to the whole-frame runs: strips, halos, the rows and instructions the
/// halos add, and the working set (method words + band window) against the 512 KiB scratch.
pub(super) fn strip_table(out: &Outcome) -> String {
    let mut s = String::from(
        "\n### Strip processing: 512 KiB working set besides the frames (`fusion_nostd::strips`)\n\n\
         | target | grid | method | strips × rows | halo | passes | method rows / grid rows | band rows | \
         working set (work + band) | instructions, strips | whole frame | strips / whole |\n\
         |---|---|---|---|---:|---:|---:|---:|---|---:|---:|---:|\n",
    );
    for StripRun { target, grid, label, report: r, count: strips, whole } in &out.strips {
        let side = grid.side();
        let _ = writeln!(
            s,
            "| {target} | {side}² | {label} | {} × {} | {} | {} | {:.3} | {} | {:.1} + {:.1} = {:.1} KiB | {strips} | {whole} | {:.3} |",
            r.strips,
            r.strip_rows,
            r.halo_rows,
            r.passes,
            r.method_rows as f64 / side as f64,
            r.band_rows,
            (r.work_words * 4) as f64 / 1024.0,
            r.band_bytes as f64 / 1024.0,
            r.working_set_bytes() as f64 / 1024.0,
            *strips as f64 / (*whole).max(1) as f64,
        );
    }
    s.push_str(
        "\nEach strip run's output is compared with the host's whole-frame `fuse` (the bit-exactness table).\n",
    );
    s
}
