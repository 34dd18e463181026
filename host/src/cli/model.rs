//! `skin model`: writes a robot's description as MuJoCo or URDF text, for
//! a user to open in MuJoCo's viewer, edit, or pass back (`--mujoco`,
//! `--urdf`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::ValueEnum;
use skin_model::robot::{hrp2, Robot, UrdfError};

/// Arguments of `skin model`.
#[derive(clap::Args)]
pub struct Args {
    /// Robot description to convert; without it, the built-in HRP-2-like upper body.
    #[arg(long, value_name = "FILE")]
    urdf: Option<PathBuf>,
    /// What to write.
    #[arg(long, value_enum, default_value_t = Format::Mjcf)]
    format: Format,
    /// File to write (standard output without it).
    #[arg(long, short, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Overwrite the --output file if it exists.
    #[arg(long, requires = "output")]
    force: bool,
}

/// A description format.
#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum Format {
    /// MuJoCo's MJCF: the same bodies, joints and limits, with masses,
    /// position servos with torque limits, the `implicitfast` integrator at 2 ms.
    Mjcf,
    /// URDF (the built-in robot's own description, or the input as read).
    Urdf,
}

/// Why `skin model` failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The output cannot be written.
    #[error(transparent)]
    Output(#[from] super::output::Error),
    /// The input description is unusable.
    #[error(transparent)]
    Urdf(#[from] UrdfError),
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    let text = match (&args.urdf, args.format) {
        (None, Format::Mjcf) => hrp2::robot().to_mjcf(),
        (None, Format::Urdf) => hrp2::urdf(),
        (Some(path), Format::Mjcf) => Robot::from_urdf_file(path).map_err(Error::from)?.to_mjcf(),
        (Some(path), Format::Urdf) => {
            // Read through the checks, so a file that would be refused later is refused now.
            Robot::from_urdf_file(path).map_err(Error::from)?;
            std::fs::read_to_string(path)
                .map_err(|source| UrdfError::Read { path: path.display().to_string(), source })?
        }
    };
    super::output::write_text(&text, args.output.as_deref(), args.force, "the robot model").map_err(Error::from)?;
    Ok(ExitCode::SUCCESS)
}
