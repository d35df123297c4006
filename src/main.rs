//! The `contact-fmu` command line: the main job (no arguments), `export`, `variables`,
//! `simulate` and `bench`.

use clap::{Parser, Subcommand};
use contact_fmu::fmi::lifecycle::Version;
use contact_fmu::run::{self, RunOptions};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "contact-fmu",
    version,
    about = "Rigid multibody dynamics with contact, as FMI 2.0 and 3.0 Co-Simulation FMUs"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Build one FMU (FMI 2.0 or 3.0) from a scene file, with the libraries for linux64 and
    /// win64.
    Export {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output .fmu (default target/fmu/<name>.fmu).
        #[arg(short, long, value_name = "OUT.fmu")]
        output: Option<PathBuf>,
        /// Also pack a library built for another platform (win64, win32, linux64, linux32,
        /// darwin64) as binaries/<PLATFORM>/<name>.<dll|so|dylib>; repeatable. One for a
        /// platform of --platforms replaces the library the exporter would find.
        #[arg(long = "binary", value_name = "PLATFORM=PATH")]
        binary: Vec<String>,
        /// The platforms whose `dist` library (built by scripts/build_fmu_library.sh from these
        /// sources) the FMU carries, comma-separated [default: linux64,win64].
        #[arg(long, value_name = "LIST")]
        platforms: Option<String>,
        /// The FMI version of the FMU: 2 (FMI 2.0) or 3 (FMI 3.0, binaries in FMI 3.0's
        /// platform folders, default output target/fmu3/<name>.fmu).
        #[arg(long, value_name = "2|3", default_value = "2", value_parser = ["2", "3"])]
        fmi_version: String,
    },
    /// List a scene's FMU variables (names for --set, causality, start values, units).
    Variables {
        /// Scene file (TOML).
        scene: PathBuf,
        #[command(flatten)]
        options: contact_fmu::run::VariablesOptions,
    },
    /// Run a scene natively (no FMI host), same engine and variable names as the FMU.
    Simulate {
        /// Scene file (TOML).
        scene: PathBuf,
        #[command(flatten)]
        options: RunOptions,
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
        None => run::main_job(std::path::Path::new("fmu"), std::path::Path::new("target")),
        Some(Command::Export {
            scene,
            output,
            binary,
            platforms,
            fmi_version,
        }) => {
            let version = if fmi_version == "3" {
                Version::Fmi3
            } else {
                Version::Fmi2
            };
            contact_fmu::export::export_command(&scene, output.as_deref(), &binary, platforms.as_deref(), version)
                .map(|e| println!("wrote {}", e.path.display()))
                .map_err(|e| e.to_string())
        }
        Some(Command::Variables { scene, options }) => run::variables_command(&scene, &options),
        Some(Command::Simulate { scene, options }) => run::simulate_command(&scene, &options).map(|_| ()),
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
