//! The `skin` command line: one module per subcommand, dispatched here.
//! The subcommands that build or serve the simulator need the `sim`
//! feature.

#[cfg(feature = "sim")]
mod calibrate;
mod cells_json;
mod config;
#[cfg(feature = "sim")]
mod demo;
#[cfg(feature = "sim")]
mod explore;
mod flash;
#[cfg(feature = "sim")]
mod grasp;
mod job;
mod keygen;
#[cfg(feature = "sim")]
mod lab;
mod live;
mod loadgen;
mod message;
mod model;
mod monitor;
#[cfg(feature = "sim")]
mod objects;
mod output;
mod progress;
mod replay;
mod run;
mod seconds;
mod sign;
#[cfg(feature = "sim")]
mod sim_endpoint;
mod structure_args;
#[cfg(feature = "sim")]
mod world;

use std::process::ExitCode;

/// The most cells a `--cells` flag takes: one per cell ID the interface hands out.
const MAX_CELLS: u64 = skin_protocol::Address::MAX_CELL as u64;

use clap::{CommandFactory, Parser, Subcommand, ValueEnum};

/// The robot PC side of a self-organizing, multi-modal robot skin.
#[derive(Parser)]
#[command(name = "skin", version)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// The main job on the built-in simulated robot and skin: organize, explore, teach, grasp, report.
    #[cfg(feature = "sim")]
    Demo(demo::Args),
    /// Learn the robot's kinematic tree and sensory-motor map from its skin (section 4).
    #[cfg(feature = "sim")]
    Explore(explore::Args),
    /// Calibrate every skin cell's pose on the robot's own URDF, in simulation: explore, then fit.
    #[cfg(feature = "sim")]
    Calibrate(calibrate::Args),
    /// Teach key poses by touch and grasp the objects of Figure 16 in simulation (sections 5 and 6).
    #[cfg(feature = "sim")]
    Grasp(grasp::Args),
    /// Write generated object files for `skin grasp --object-file`: seeded shapes, sizes, masses, frictions, and placements anywhere both arms reach.
    #[cfg(feature = "sim")]
    Objects(objects::GenerateArgs),
    /// Watch the skin live: cells, rates, tactile events, drops.
    Monitor(monitor::Args),
    /// Write the default configuration file, or check one.
    Config(config::Args),
    /// Write a robot's description for MuJoCo (MJCF) or as URDF: the built-in robot, or a URDF converted.
    Model(model::Args),
    /// The main job against a real skin and robot (or an external simulator): organize, explore, report.
    Run(Box<run::Args>),
    /// Feed a recording (`skin run --record`, `skin demo`) to the host instead of the network.
    Replay(replay::Args),
    /// Serve the built-in simulated robot and skin on loopback UDP, for `skin run` in another terminal.
    #[cfg(feature = "sim")]
    SimEndpoint(sim_endpoint::Args),
    /// Simulate a skin that sends interface datagrams to a host (for measuring and watching without hardware).
    Loadgen(loadgen::Args),
    /// Make a new firmware update key pair (secret key and FILE.pub).
    Keygen(keygen::Args),
    /// Sign a cell program into a firmware image, or check an image (--check).
    Sign(sign::Args),
    /// Update every cell of the skin to a signed image through the interface ports.
    Flash(flash::Args),
    /// Print a reference page of the book (generated, compared by a test).
    #[command(hide = true)]
    Reference {
        /// Which page.
        page: ReferencePage,
    },
}

/// The book's generated reference pages.
#[derive(Clone, Copy, ValueEnum)]
enum ReferencePage {
    /// `docs/src/reference/cli.md`.
    Cli,
    /// `docs/src/reference/config.md`.
    Config,
}

/// Runs the subcommand; errors are printed as one line, never a backtrace.
pub fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        // RustDDS logs every peer it has no route to yet and, on loopback
        // only, each multicast group it cannot leave: silent unless asked.
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| "warn,rustdds=off,ros2_client=error".into()),
        )
        .init();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // A value out of its range is one line naming the flag and the range.
        Err(e) if e.kind() == clap::error::ErrorKind::ValueValidation => {
            eprintln!("{}", e.to_string().lines().next().unwrap_or_default());
            return ExitCode::from(2);
        }
        Err(e) => e.exit(),
    };
    let result = match cli.command {
        #[cfg(feature = "sim")]
        Command::Demo(args) => demo::run(args),
        #[cfg(feature = "sim")]
        Command::Explore(args) => explore::run(args),
        #[cfg(feature = "sim")]
        Command::Calibrate(args) => calibrate::run(args),
        #[cfg(feature = "sim")]
        Command::Grasp(args) => grasp::run(args),
        #[cfg(feature = "sim")]
        Command::Objects(args) => objects::generate(args),
        Command::Monitor(args) => monitor::run(args),
        Command::Config(args) => config::run(args),
        Command::Model(args) => model::run(args),
        Command::Loadgen(args) => loadgen::run(args),
        Command::Run(args) => run::run(*args),
        Command::Replay(args) => replay::run(args),
        #[cfg(feature = "sim")]
        Command::SimEndpoint(args) => sim_endpoint::run(args),
        Command::Keygen(args) => keygen::run(args),
        Command::Sign(args) => sign::run(args),
        Command::Flash(args) => flash::run(args),
        Command::Reference { page } => {
            print!(
                "{}",
                match page {
                    ReferencePage::Cli => skin_host::reference::cli_markdown(&Cli::command()),
                    ReferencePage::Config => skin_host::reference::config_markdown(),
                }
            );
            Ok(ExitCode::SUCCESS)
        }
    };
    result.unwrap_or_else(|e| {
        eprintln!("error: {}", message::cut(&e.to_string()));
        ExitCode::FAILURE
    })
}
