//! The `talus` command line.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use talus::case::Case;
use talus::run::{run, RunOptions};
use talus::TalusError;

#[derive(Parser)]
#[command(name = "talus", version, about = "A discrete element method engine for granular flow")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Run a case file.
    Run {
        /// The case file (TOML).
        case: PathBuf,
        /// Output folder (default: out/<case name>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Stop after N steps (benchmarks, regression checks).
        #[arg(long)]
        steps: Option<u64>,
        /// Continue from a checkpoint written by an earlier run of the same case.
        #[arg(long)]
        restart: Option<PathBuf>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
    },
    /// Write the H1 hopper meshes (hopper.stl, box.stl) into a folder.
    Meshes { dir: PathBuf },
    /// Write a case's initial particles as CSV (id,x,y,z,radius,vx,vy,vz), for the other engines.
    Cloud {
        case: PathBuf,
        #[arg(long)]
        out: PathBuf,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match real_main(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("talus: error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn real_main(cli: Cli) -> Result<(), TalusError> {
    match cli.cmd {
        Cmd::Run { case, out, steps, restart, quiet } => {
            let c = Case::load(&case)?;
            let out = out.unwrap_or_else(|| {
                PathBuf::from("out").join(case.file_stem().map(|s| s.to_os_string()).unwrap_or_default())
            });
            let opts = RunOptions { out: out.clone(), max_steps: steps, restart, progress: !quiet };
            let r = run(c, &opts)?;
            println!("talus: {} finished; outputs in {}", case.display(), out.display());
            for (k, v) in &r.summary {
                println!("  {k:<32} {v}");
            }
            Ok(())
        }
        Cmd::Meshes { dir } => {
            std::fs::create_dir_all(&dir).map_err(|e| TalusError::io(format!("creating {}", dir.display()), e))?;
            let (h, b) = talus::generate::hopper_meshes();
            for (m, name) in [(h, "hopper.stl"), (b, "box.stl")] {
                let p = dir.join(name);
                m.write_stl(&p).map_err(|e| TalusError::io(format!("writing {}", p.display()), e))?;
                println!("wrote {}", p.display());
            }
            Ok(())
        }
        Cmd::Cloud { case, out } => {
            let c = Case::load(&case)?;
            let sim = talus::sim::Simulation::new(c)?;
            let inits = sim.state.p.to_inits();
            talus::generate::write_csv(&out, &inits).map_err(|e| TalusError::io(format!("writing {}", out.display()), e))?;
            println!("wrote {} particles to {}", inits.len(), out.display());
            Ok(())
        }
    }
}
