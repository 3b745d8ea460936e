//! `fusion campaign`: Monte Carlo campaigns of the navigation judge (`fusion_campaign`).
//! `plan` lists a campaign file's cases with their stable ids; the runs themselves are the
//! Python package's (`vistir-campaign run`, on Dask).

use anyhow::Result;
use clap::{Args, Subcommand};
use fusion_campaign::file::CampaignFile;
use fusion_campaign::plan::{fingerprint, plan};
use fusion_io::outln;
use std::path::PathBuf;

/// Arguments of `fusion campaign`.
#[derive(Debug, Args)]
pub struct CampaignArgs {
    /// What to do.
    #[command(subcommand)]
    pub command: CampaignCommand,
}

/// The campaign verbs.
#[derive(Debug, Subcommand)]
pub enum CampaignCommand {
    /// List a campaign file's cases: id, parameters, sensor seed (one per line, or JSON).
    Plan {
        /// The campaign file (TOML; README "Campaigns").
        file: PathBuf,
        /// Print the cases as a JSON array instead of a table.
        #[arg(long)]
        json: bool,
    },
}

fn opt(v: Option<f64>, none: &str) -> String {
    v.map_or(none.to_string(), |x| format!("{x:.6}").trim_end_matches('0').trim_end_matches('.').to_string())
}

/// Runs `fusion campaign`.
pub fn run(args: &CampaignArgs) -> Result<()> {
    match &args.command {
        CampaignCommand::Plan { file, json } => {
            let f = CampaignFile::read(file)?;
            let cases = plan(&f)?;
            if *json {
                outln!("{}", serde_json::to_string_pretty(&cases)?)?;
                return Ok(());
            }
            outln!(
                "# campaign {}: {} cases, plan {}, streams {}",
                f.name,
                cases.len(),
                fingerprint(&f.name, &cases),
                cases.first().map(|c| c.sources.join(",")).unwrap_or_default()
            )?;
            outln!("id\ttrajectory\ttarget\tearth_km\tsun_phase_deg\tglare\treplica\tseed")?;
            for c in &cases {
                outln!(
                    "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}",
                    c.id,
                    c.trajectory.as_str(),
                    c.target.as_str(),
                    opt(c.earth_km, "-"),
                    opt(c.sun_phase_deg, "own"),
                    c.glare,
                    c.replica,
                    c.seed
                )?;
            }
            Ok(())
        }
    }
}
