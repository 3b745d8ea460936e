//! `fusion campaign`: Monte Carlo campaigns of the navigation judge (`fusion_campaign`).
//! `plan` lists a campaign file's cases with their stable ids; the runs themselves are the
//! Python package's (`vistir-campaign run`, on Dask).

use anyhow::Result;
use clap::{Args, Subcommand};
use fusion_campaign::file::CampaignFile;
use fusion_campaign::plan::{plan, table};
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
            fusion_io::console::stdout_write(format_args!("{}", table(&f.name, &cases)))?;
            Ok(())
        }
    }
}
