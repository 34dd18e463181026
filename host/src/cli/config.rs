//! `skin config`: writes the default configuration, or checks a file.

use std::io::Write;
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
    /// The output file exists and --force was not given.
    #[error("{0} exists; pass --force to overwrite it")]
    Exists(PathBuf),
    /// The output could not be written.
    #[error("cannot write {path}: {source}")]
    Write {
        /// Where.
        path: String,
        /// What the OS said.
        source: std::io::Error,
    },
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
    match &args.output {
        Some(path) => {
            if path.exists() && !args.force {
                return Err(Error::Exists(path.clone()).into());
            }
            std::fs::write(path, text).map_err(|source| Error::Write { path: path.display().to_string(), source })?;
            eprintln!("wrote the default configuration to {}", path.display());
        }
        None => std::io::stdout()
            .write_all(text.as_bytes())
            .map_err(|source| Error::Write { path: "standard output".into(), source })?,
    }
    Ok(ExitCode::SUCCESS)
}
