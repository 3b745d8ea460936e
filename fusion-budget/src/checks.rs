//! The budget check: measured counts against the committed `fw/budgets.toml` table, and the
//! table's text rewritten from a run.

#[allow(unused_imports)]
use super::*;

/// Measurements of one method on one target and grid.
#[derive(Debug, Clone, PartialEq)]
pub struct Measured {
    /// Target.
    pub target: Target,
    /// Grid.
    pub grid: Grid,
    /// Method.
    pub method: MethodArg,
    /// Stage rows.
    pub stages: Vec<Stage>,
}

impl Measured {
    /// Output pixels (the fusion grid).
    pub fn pixels(&self) -> u64 {
        (self.grid.side() * self.grid.side()) as u64
    }

    /// Instructions per output pixel of a stage.
    pub fn per_px(&self, s: &Stage) -> f64 {
        s.count as f64 / self.pixels() as f64
    }

    /// The whole-pipeline count.
    pub fn pipeline(&self) -> u64 {
        self.stages.iter().find(|s| s.key == "pipeline").map_or(0, |s| s.count)
    }

    /// Budget-table key of a stage.
    pub fn key(&self, stage: &str) -> String {
        format!("{}.{}.{}.{}", self.target, self.grid.side(), method_key(self.method), stage)
    }
}

/// The outcome of checking measurements against the table.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Check {
    /// Keys over budget, with measured and budget instr/px.
    pub over: Vec<(String, f64, f64)>,
    /// Keys with no budget entry.
    pub missing: Vec<String>,
    /// Keys more than 10 % under budget (time to tighten).
    pub slack: Vec<(String, f64, f64)>,
    /// Keys checked.
    pub checked: usize,
}

impl Check {
    /// No entry over budget and none missing.
    pub fn passed(&self) -> bool {
        self.over.is_empty() && self.missing.is_empty()
    }
}

/// Checks every measured stage (and AGC run) against `budgets`.
pub fn check(measured: &[Measured], agc: &[TirMeasured], budgets: &Table) -> Check {
    let mut c = Check::default();
    let entries = measured
        .iter()
        .flat_map(|m| m.stages.iter().map(move |s| (m.key(s.key), m.per_px(s))))
        .chain(agc.iter().map(|a| (a.key(), a.per_px())));
    for (key, got) in entries {
        c.checked += 1;
        match budgets.get(&key) {
            None => c.missing.push(key),
            Some(b) if got > b => c.over.push((key, got, b)),
            Some(b) if got < b / 1.10 => c.slack.push((key, got, b)),
            Some(_) => {}
        }
    }
    c
}

/// A budget table (TOML text) for these measurements: measured + 2 %, rounded up to 0.1
/// instr/px; `goals` lines are copied from `old`.
pub fn budget_table_text(measured: &[Measured], agc: &[TirMeasured], old: &Table) -> String {
    let mut s = String::from(
        "# Instruction budgets of the fusion core on the emulated flight targets, in instructions per\n\
         # output pixel of the fusion grid (exact counts / W·H), checked by `fusion budget`.\n\
         # Written by `fusion budget --write-budgets` as measured + 2 %, rounded up to 0.1; tighten\n\
         # them as the code gets faster, never loosen them without saying why in the commit.\n\
         # Keys: [<target>.<grid side>.<method>] then one line per stage (see fw/README.md).\n",
    );
    for m in measured {
        let _ = writeln!(s, "\n[{}.{}.{}]", m.target, m.grid.side(), method_key(m.method));
        for st in &m.stages {
            let _ = writeln!(s, "{} = {}", st.key, table::budget_for(m.per_px(st), 0.02, 0.1));
        }
    }
    let mut header = String::new();
    for a in agc {
        let table = format!("{}.{}.{}", a.target, a.size.0, a.stage.table());
        if table != header {
            let line = match a.stage {
                crate::TirStage::Agc(_) => format!(
                    "The thermal AGC (fusion_nostd::agc) on a {}x{} 14-bit TIR frame, per TIR pixel.",
                    a.size.0, a.size.1
                ),
                crate::TirStage::Thermal(_) => format!(
                    "The thermal front end's stages (fusion_nostd::thermal, then the linear AGC) on a {}x{} 14-bit TIR frame, per TIR pixel (the most any frame of the budget job's {}-frame raw sequence took).",
                    a.size.0,
                    a.size.1,
                    crate::inputs::THERMAL_FRAMES
                ),
                crate::TirStage::Registration(_) => format!(
                    "Registration of the budget pair's TIR frame onto its {}x{} visible grid through the default offset rig at {} m (fusion_nostd::registration), per visible pixel: the node grid, the strips linear and cubic.",
                    a.size.0,
                    a.size.1,
                    crate::REGISTRATION_RANGE_M
                ),
            };
            let _ = writeln!(s, "\n# {line}\n[{table}]");
            header = table;
        }
        let _ = writeln!(s, "{} = {}", a.stage.name(), table::budget_for(a.per_px(), 0.02, 0.1));
    }
    let goals: Vec<_> = old.iter().filter(|(k, _)| k.starts_with("goal.")).collect();
    if !goals.is_empty() {
        s.push_str("\n# The issue's targets for the whole pipeline (reported, not enforced).\n");
        let mut header = String::new();
        for (k, v) in goals {
            let (table, key) = k.rsplit_once('.').unwrap_or((k, ""));
            if table != header {
                let _ = writeln!(s, "[{table}]");
                header = table.to_string();
            }
            let _ = writeln!(s, "{key} = {v}");
        }
    }
    s
}
