//! The committed budget table (`fw/budgets.toml`): a small TOML subset — `[a.b.c]` tables,
//! `key = number` lines and `#` comments — read without a TOML dependency. Anything else is an
//! error, so a typo cannot silently drop a budget.
//!
//! ```toml
//! [arm.1024.tsifsd]          # target . grid side . method
//! pipeline = 372.0           # instructions per output pixel
//! rescale = 25.5
//!
//! [goal.arm.1024]            # the issue's targets, reported (not enforced)
//! tsifsd = 120
//! ```

use anyhow::{Result, bail};
use std::collections::BTreeMap;

/// Parsed table: dotted key (`arm.1024.tsifsd.pipeline`) → value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    entries: BTreeMap<String, f64>,
}

fn is_bare_key(s: &str) -> bool {
    !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

impl Table {
    /// Parses the TOML subset.
    pub fn parse(text: &str) -> Result<Table> {
        let mut entries = BTreeMap::new();
        let mut prefix = String::new();
        for (i, raw) in text.lines().enumerate() {
            let line_no = i + 1;
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            if let Some(inner) = line.strip_prefix('[') {
                let Some(name) = inner.strip_suffix(']') else {
                    bail!("line {line_no}: unterminated table header");
                };
                let name = name.trim();
                if !name.split('.').all(is_bare_key) {
                    bail!("line {line_no}: bad table name {name:?}");
                }
                prefix = name.to_string();
                continue;
            }
            let Some((key, value)) = line.split_once('=') else {
                bail!("line {line_no}: expected `key = number`");
            };
            let key = key.trim();
            if !is_bare_key(key) {
                bail!("line {line_no}: bad key {key:?}");
            }
            let value: f64 = match value.trim().replace('_', "").parse() {
                Ok(v) if f64::is_finite(v) && v >= 0.0 => v,
                _ => bail!("line {line_no}: {key} must be a non-negative number"),
            };
            let full = if prefix.is_empty() { key.to_string() } else { format!("{prefix}.{key}") };
            if entries.insert(full.clone(), value).is_some() {
                bail!("line {line_no}: {full} given twice");
            }
        }
        Ok(Table { entries })
    }

    /// The value at a dotted path.
    pub fn get(&self, path: &str) -> Option<f64> {
        self.entries.get(path).copied()
    }

    /// Every `(path, value)`, sorted by path.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.entries.iter().map(|(k, &v)| (k.as_str(), v))
    }
}

/// A budget for a measured value: `measured · (1 + margin)` rounded up to a multiple of
/// `step` (so re-running on the same code never fails by rounding).
pub fn budget_for(measured: f64, margin: f64, step: f64) -> f64 {
    let raw = measured * (1.0 + margin);
    let b = (raw / step).ceil() * step;
    // Keep the printed decimal value tidy (0.1 steps are not exact in binary).
    (b * 1000.0).round() / 1000.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_tables_keys_and_comments() -> Result<()> {
        let t = Table::parse(
            "# header\n\n[arm.1024.tsifsd]\npipeline = 372.5 # per px\nrescale=25\n\n[goal.arm.1024]\ntsifsd = 1_20\n",
        )?;
        assert_eq!(t.get("arm.1024.tsifsd.pipeline"), Some(372.5));
        assert_eq!(t.get("arm.1024.tsifsd.rescale"), Some(25.0));
        assert_eq!(t.get("goal.arm.1024.tsifsd"), Some(120.0));
        assert_eq!(t.get("arm.512.tsifsd.pipeline"), None);
        assert_eq!(t.iter().count(), 3);
        Ok(())
    }

    #[test]
    fn rejects_what_it_does_not_understand() {
        for bad in [
            "[arm.1024\nx = 1",
            "[arm..1024]\nx = 1",
            "x = \"text\"",
            "x = -1",
            "x = nan",
            "just words",
            "a b = 1",
            "x = 1\nx = 2",
            "x = [1, 2]",
        ] {
            assert!(Table::parse(bad).is_err(), "accepted {bad:?}");
        }
    }

    #[test]
    fn budgets_round_up_with_margin() {
        assert_eq!(budget_for(100.0, 0.02, 0.5), 102.0);
        assert_eq!(budget_for(100.01, 0.02, 0.5), 102.5);
        assert_eq!(budget_for(25.43, 0.02, 0.1), 26.0);
        assert!(budget_for(365.27, 0.02, 0.1) >= 365.27 * 1.02);
    }
}
