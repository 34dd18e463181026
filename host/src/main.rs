//! `skin`: the robot PC program. Each subcommand lives in its own module
//! under `cli/`; this file only hands over.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
