//! `skin keygen`: a new update key pair.

use std::path::PathBuf;
use std::process::ExitCode;

use skin_host::update::keys;

/// Arguments of `skin keygen`.
#[derive(clap::Args)]
pub struct Args {
    /// Secret key file to write (PEM, owner-only); the public key goes to FILE.pub.
    #[arg(long, short, value_name = "FILE", default_value = "update.key")]
    out: PathBuf,
    /// Replace existing key files.
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let public = keys::generate(&args.out, args.force)?;
    let hex: String = public.iter().map(|b| format!("{b:02x}")).collect();
    println!(
        "wrote {} (secret: keep it off the robot) and {} (public key {hex}: build it into the cells)",
        args.out.display(),
        keys::public_path(&args.out).display()
    );
    Ok(ExitCode::SUCCESS)
}
