//! The `contact-fmu` command line: the main job (no arguments), `export` and `simulate`.

use clap::{Parser, Subcommand};
use contact_fmu::run::{self, RunOptions};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "contact-fmu",
    version,
    about = "Rigid multibody dynamics with contact, as FMI 2.0 Co-Simulation FMUs"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Build one FMU from a scene file.
    Export {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output .fmu (default target/fmu/<name>.fmu).
        #[arg(short, long)]
        o: Option<PathBuf>,
    },
    /// Run a scene natively (no FMI host), same engine and variable names as the FMU.
    Simulate {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Stop time [s] (default: the scene's stop_time).
        #[arg(long)]
        stop_time: Option<f64>,
        /// Communication interval [s] (default: the scene's interval).
        #[arg(long)]
        interval: Option<f64>,
        /// Set a parameter or input: NAME=VALUE (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Write the outputs at every communication point to this CSV file.
        #[arg(long)]
        csv: Option<PathBuf>,
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
        /// Write the state at the stop time to this file (a checkpoint to resume from).
        #[arg(long, value_name = "FILE")]
        save_state: Option<PathBuf>,
        /// Start from a state saved with --save-state (of the same scene) instead of the
        /// initial configuration; --stop-time must lie after its time.
        #[arg(long, value_name = "FILE")]
        resume: Option<PathBuf>,
    },
    /// Benchmarks: work-precision, stress, scaling, targets (tables and CSV).
    Bench {
        #[command(subcommand)]
        what: contact_fmu::bench::BenchCommand,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        None => run::main_job(std::path::Path::new("fmu"), std::path::Path::new("target/fmu")),
        Some(Command::Export { scene, o }) => contact_fmu::export::export_command(&scene, o.as_deref())
            .map(|e| println!("wrote {}", e.path.display()))
            .map_err(|e| e.to_string()),
        Some(Command::Simulate {
            scene,
            stop_time,
            interval,
            set,
            csv,
            quiet,
            save_state,
            resume,
        }) => run::simulate_command(
            &scene,
            &RunOptions {
                stop_time,
                interval,
                set,
                csv,
                quiet,
                save_state,
                resume,
            },
        )
        .map(|_| ()),
        Some(Command::Bench { what }) => contact_fmu::bench::bench_command(what),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(msg) => {
            eprintln!("error: {msg}");
            ExitCode::FAILURE
        }
    }
}
