//! `skin config`: writes the default configuration, or checks a file.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::ArgGroup;
use skin_host::config::Config;

/// Arguments of `skin config`.
#[derive(clap::Args)]
#[command(group(ArgGroup::new("action").required(true).args(["default", "check"])))]
pub struct Args {
    /// Write every key with its default value (to standard output, or --output).
    #[arg(long)]
    default: bool,
    /// File to write the defaults to.
    #[arg(long, short, value_name = "FILE", requires = "default")]
    output: Option<PathBuf>,
    /// Overwrite the --output file if it exists.
    #[arg(long, requires = "output")]
    force: bool,
    /// Check a configuration file and summarize it.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
    /// With --check: print the complete configuration in effect as JSON.
    #[arg(long, requires = "check")]
    json: bool,
}

/// Why `skin config` failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The output cannot be written.
    #[error(transparent)]
    Output(#[from] super::output::Error),
    /// The file to check is unusable.
    #[error(transparent)]
    Config(#[from] skin_host::config::Error),
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    if let Some(path) = &args.check {
        let config = Config::load(path)?;
        if args.json {
            println!("{}", serde_json::to_string_pretty(&config)?);
        } else {
            let i = &config.interface;
            let bound = i.ports.iter().filter(|p| p.address.is_some()).count();
            println!(
                "{}: valid. Listens on {} for {} interface ports ({bound} with a fixed address); \
                 cells sample at {} Hz, {:?}-driven, {} settings written at start.",
                path.display(),
                i.listen,
                i.ports.len(),
                config.cells.sample_rate_hz,
                config.cells.traffic,
                config.cells.settings().len()
            );
        }
        return Ok(ExitCode::SUCCESS);
    }
    let text = Config::default().to_toml();
    super::output::write_text(&text, args.output.as_deref(), args.force, "the default configuration")
        .map_err(Error::from)?;
    Ok(ExitCode::SUCCESS)
}
