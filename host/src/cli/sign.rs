//! `skin sign`: a program's bytes into a signed firmware image, or
//! `--check` an image as a cell would.

use std::path::PathBuf;
use std::process::ExitCode;

use skin_host::update::{keys, signing};
use skin_protocol::image::Board;

/// Arguments of `skin sign`.
#[derive(clap::Args)]
pub struct Args {
    /// The program (a raw binary, as `objcopy -O binary` or `cargo xtask image` writes it), or with --check the image.
    #[arg(value_name = "IMAGE")]
    input: PathBuf,
    /// Secret key file (from `skin keygen`); with --check, the public key file.
    #[arg(long, value_name = "FILE", default_value = "update.key")]
    key: PathBuf,
    /// The board the program is built for.
    #[arg(long, value_parser = parse_board, default_value = "mps2-an386")]
    board: Board,
    /// The firmware version the cells will report.
    #[arg(long, required_unless_present = "check")]
    version: Option<u32>,
    /// Where to write the image (default: IMAGE.skfw).
    #[arg(long, short, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Check a signed image against a public key instead of signing.
    #[arg(long, conflicts_with_all = ["version", "out"])]
    check: bool,
}

fn parse_board(name: &str) -> Result<Board, String> {
    Board::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = Board::ALL.iter().map(|b| b.name()).collect();
        format!("unknown board {name:?}; one of {}", names.join(", "))
    })
}

pub fn run(args: Args) -> Result<ExitCode, Box<dyn std::error::Error>> {
    if args.check {
        let header = signing::check_file(&args.input, args.board, &keys::load_public(&args.key)?)?;
        println!(
            "{}: valid image, version {} for {}, body {} bytes, SHA-256 {}",
            args.input.display(),
            header.version,
            header.board.name(),
            header.body_len,
            header.body_sha256.iter().map(|b| format!("{b:02x}")).collect::<String>()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let key = keys::load_secret(&args.key)?;
    let version = args.version.ok_or("--version is required to sign")?;
    let image = signing::sign_file(&args.input, args.board, version, &key)?;
    let out = args.out.unwrap_or_else(|| args.input.with_extension("skfw"));
    std::fs::write(&out, &image).map_err(|source| skin_host::update::Error::Write { path: out.clone(), source })?;
    println!("wrote {} ({} bytes, version {version} for {})", out.display(), image.len(), args.board.name());
    Ok(ExitCode::SUCCESS)
}
