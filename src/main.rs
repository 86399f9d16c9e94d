//! The `talus` command line.

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;
use talus::case::Case;
use std::rc::Rc;
use talus::parallel::agreed;
use talus::parallel::comm::Comm;
use talus::run::{run_on, RunOptions};
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
        #[arg(long, value_name = "N", allow_negative_numbers = true)]
        steps: Option<String>,
        /// Continue from a checkpoint written by an earlier run of the same case.
        #[arg(long)]
        restart: Option<PathBuf>,
        /// No progress bar.
        #[arg(long)]
        quiet: bool,
        /// Override the case's `[parallel] balance` (off, count, time, contacts).
        #[arg(long)]
        balance: Option<String>,
        /// Change one value of the case: KEY=VALUE, KEY a dotted path
        /// (`contact.convention=yade`, `material[0].restitution=0.3`,
        /// `wall.gate.velocity=[0,0,-0.1]`), VALUE a TOML value. Repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
        /// Threads per rank (the case's `[parallel] threads`; default: the
        /// cores available, shared among the ranks). Results do not depend on it.
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
    },
    /// Run a drag case (the drag paper, CASES.md D2) over its seeded beds.
    Drag {
        /// A drag case file (cases/drag/<id>.toml).
        case: PathBuf,
        /// Output folder (default: out/drag/<id>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Do not drag: write bed SEED, grown and settled, as an ordinary case
        /// (<id>-bed<SEED>.toml and .csv in the output folder) for `talus run` and `talus export`.
        #[arg(long, value_name = "SEED")]
        bed_case: Option<u64>,
        /// Beds run side by side, one thread each (default: the cores available).
        #[arg(long, value_name = "N", value_parser = at_least_one)]
        threads: Option<usize>,
    },
    /// Write a case as an input for a reference code (LIGGGHTS 3.8, YADE 2023, LAMMPS 29Sep2021), with its particle and mesh files,
    /// writing the same probes as talus's probes.csv; what the code cannot run is refused naming the key.
    Export {
        case: PathBuf,
        /// The reference code: liggghts, yade or lammps.
        #[arg(long)]
        to: String,
        /// Output folder (default: out/export/<case name>-<code>).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Change one value of the case before exporting it, as `talus run --set`. Repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
        /// A case that inserts particles: the inserted.csv of a talus run of it, whose
        /// particles the export brings in at the same steps.
        #[arg(long)]
        inserted: Option<PathBuf>,
    },
    /// Continuum fields from a run's snapshots: coarse-grained density, velocity and stress
    /// (kinetic + contact, compression positive), averaged over the snapshots from --from to --to.
    /// A profile goes to profile_<axis>.csv, a grid to fields.h5 + fields.xdmf (ParaView).
    /// The contact stress needs snapshots with contacts (output.contacts = true).
    Fields {
        /// The run's output folder (holding snapshots.h5), or a snapshots.h5 file.
        run: PathBuf,
        /// The kernel: gauss (width: standard deviation, cut off at 3 widths) or lucy (width: radius).
        #[arg(long, default_value = "gauss")]
        kernel: String,
        /// The kernel's width (m); about a particle diameter resolves a profile.
        #[arg(long)]
        width: f64,
        /// A grid of NX,NY,NZ cells over the domain (HDF5 + XDMF).
        #[arg(long, value_name = "NX,NY,NZ", conflicts_with = "profile")]
        grid: Option<String>,
        /// A profile along x, y or z: the fields averaged over the other two axes (CSV).
        #[arg(long, value_name = "AXIS")]
        profile: Option<String>,
        /// Points of a profile (default 100).
        #[arg(long, value_name = "N")]
        points: Option<usize>,
        /// First snapshot time used (s).
        #[arg(long, value_name = "T0", allow_negative_numbers = true)]
        from: Option<f64>,
        /// Last snapshot time used (s).
        #[arg(long, value_name = "T1", allow_negative_numbers = true)]
        to: Option<f64>,
        /// Output folder (default: the run's folder).
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Print the JSON Schema of a case file (draft 7): every section and key with its type,
    /// default and documentation. Editors that check TOML against a JSON Schema (taplo,
    /// Even Better TOML) check case files with it as one types.
    Schema,
    /// Write the H1 hopper meshes (hopper.stl, box.stl) into a folder.
    Meshes { dir: PathBuf },
    /// Write a case's initial particles as CSV (id,x,y,z,radius,vx,vy,vz), for the other engines;
    /// with --restart, the particles of a checkpoint of that case (say, the end of a fill).
    Cloud {
        case: PathBuf,
        #[arg(long)]
        out: PathBuf,
        /// A checkpoint written by a run of the same case: its particles, not the initial ones.
        #[arg(long)]
        restart: Option<PathBuf>,
        /// Change one value of the case first, as `talus run --set`. Repeatable.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        sets: Vec<String>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // MPI only when started by mpirun (P = 1 runs without it)
    let comm = Rc::new(Comm::init());
    let (rank, size) = (comm.rank(), comm.size());
    if size > 1 {
        // a rank that panics ends the whole job, naming itself and the cause
        std::panic::set_hook(Box::new(move |info| {
            eprintln!("talus: rank {rank} of {size} failed: {info}; ending the job");
            talus::parallel::comm::abort_world(70);
        }));
    }
    let result = real_main(cli, comm);
    match result {
        Ok(code) => code,
        Err(e) => {
            // errors are collective (every rank has the same message): rank 0 prints
            // it at once; the others wait a moment before exiting (mpirun ends the job
            // when the first process fails, which must not cut rank 0 short). Input
            // errors come from checks every rank makes on the same input (the one
            // machine-dependent check, memory, is agreed on collectively), so rank 0
            // has the same one: only rank 0 prints it. Other errors are printed by
            // the other ranks too if they are still running, i.e. if rank 0 did not fail
            if rank == 0 {
                talus::parallel::comm::say(&format!("talus: error: {e}"));
            } else {
                std::thread::sleep(std::time::Duration::from_millis(500));
                if !matches!(e, TalusError::Input(_)) {
                    talus::parallel::comm::say(&format!("talus: error (rank {rank} of {size}): {e}"));
                }
            }
            ExitCode::FAILURE
        }
    }
}

fn real_main(cli: Cli, comm: Rc<Comm>) -> Result<ExitCode, TalusError> {
    match cli.cmd {
        Cmd::Run { case, out, steps, restart, quiet, balance, sets, threads } => {
            let root = comm.is_root();
            let steps = steps
                .map(|s| {
                    s.parse::<u64>().map_err(|_| {
                        TalusError::Input(format!("--steps {s}: must be a whole number of steps, 0 or more"))
                    })
                })
                .transpose()?;
            let mut sets = sets;
            if let Some(t) = threads {
                // checked with the case's other values
                sets.push(format!("parallel.threads={t}"));
            }
            // every rank reads the case: one that cannot stops them all
            let mut c = agreed(&comm, Case::load_with(&case, &sets))?;
            if let Some(b) = balance {
                c.parallel.balance = serde_json::from_value(serde_json::Value::String(b.clone())).map_err(|_| {
                    TalusError::Input(format!("--balance {b}: must be one of off, count, time, contacts"))
                })?;
            }
            let out = out.unwrap_or_else(|| {
                PathBuf::from("out").join(case.file_stem().map(|s| s.to_os_string()).unwrap_or_default())
            });
            let opts = RunOptions { out: out.clone(), max_steps: steps, restart, progress: !quiet };
            // SIGINT / SIGTERM: finish the step, write the checkpoint and outputs, exit 130 / 143
            agreed(&comm, talus::signals::install().map_err(|e| TalusError::io("installing the SIGINT/SIGTERM handlers", e)))?;
            let r = run_on(c, &opts, comm)?;
            if let Some(sig) = r.interrupted {
                if root {
                    let st = r.sim.state();
                    eprintln!(
                        "talus: stopped by {} at step {} (t = {:.6e} s); checkpoint and outputs written in {}; continue with: talus run {} --out {} --restart {}",
                        talus::signals::name(sig),
                        st.step,
                        st.time,
                        out.display(),
                        case.display(),
                        out.display(),
                        out.join("checkpoint.bin").display()
                    );
                }
                return Ok(ExitCode::from(talus::signals::exit_code(sig)));
            }
            if root {
                println!("talus: {} finished; outputs in {}", case.display(), out.display());
                for (k, v) in &r.summary {
                    println!("  {k:<32} {v}");
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Drag { case, out, bed_case, threads } => {
            let mut dc = agreed(&comm, talus::drag::DragCase::load(&case))?;
            dc.threads = threads;
            let out = out.unwrap_or_else(|| PathBuf::from("out").join("drag").join(&dc.drag.id));
            if let Some(seed) = bed_case {
                if !comm.is_root() {
                    return Ok(ExitCode::SUCCESS); // one bed, written once (by rank 0)
                }
                let f = talus::drag::write_bed_case(&dc, seed, &out)?;
                println!("talus: wrote {} (bed {seed} of drag case {}, at the start of the drag)", f.display(), dc.drag.id);
                return Ok(ExitCode::SUCCESS);
            }
            // under mpirun the beds are dealt to the ranks; rank 0 writes and reports
            let s = talus::drag::run_on(&dc, &out, &comm)?;
            if comm.is_root() {
                println!("talus: drag case {} finished; outputs in {}", dc.drag.id, out.display());
                for (k, v) in &s {
                    println!("  {k:<24} {v}");
                }
            }
            Ok(ExitCode::SUCCESS)
        }
        // the commands that only write files: under mpirun, rank 0 writes them once
        Cmd::Export { .. } | Cmd::Meshes { .. } | Cmd::Cloud { .. } | Cmd::Fields { .. } | Cmd::Schema if !comm.is_root() => Ok(ExitCode::SUCCESS),
        Cmd::Schema => {
            println!("{}", serde_json::to_string_pretty(&talus::case::schema()).expect("a JSON value"));
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Fields { run, kernel, width, grid, profile, points, from, to, out } => {
            let grid = grid
                .map(|g| {
                    let v: Vec<usize> = g.split(',').filter_map(|x| x.trim().parse().ok()).collect();
                    <[usize; 3]>::try_from(v).map_err(|_| TalusError::Input(format!("--grid {g}: must be three whole numbers NX,NY,NZ")))
                })
                .transpose()?;
            let (k, pts) = talus::fields::plan(&kernel, width, profile.as_deref(), grid, points)
                .map_err(|(key, v, why)| TalusError::Input(format!("--{key} {v}: {why}")))?;
            let r = talus::fields::from_snapshots(&run, k, pts, from, to)?;
            for w in &r.warnings {
                eprintln!("talus: warning: {w}");
            }
            let out = out.unwrap_or_else(|| if run.is_dir() { run.clone() } else { run.parent().map(|p| p.to_path_buf()).unwrap_or_default() });
            std::fs::create_dir_all(&out).map_err(|e| TalusError::io(format!("creating {}", out.display()), e))?;
            let f = r.fields.write_to(&out)?;
            println!("wrote {} ({} snapshots from t = {:.6e} s to {:.6e} s, {} contacts in the last)", f.display(), r.fields.samples, r.first, r.last, r.contacts);
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Export { case, to, out, sets, inserted } => {
            let target = talus::export::Target::parse(&to)?;
            let c = Case::load_with(&case, &sets)?;
            let stem = case.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
            let out = out.unwrap_or_else(|| PathBuf::from("out").join("export").join(format!("{stem}-{to}")));
            let e = talus::export::export_with(&c, target, &out, inserted.as_deref())?;
            for f in &e.files {
                println!("wrote {}", f.display());
            }
            for n in &e.notes {
                println!("note: {n}");
            }
            println!("run: {}", e.command);
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Meshes { dir } => {
            std::fs::create_dir_all(&dir).map_err(|e| TalusError::io(format!("creating {}", dir.display()), e))?;
            let (h, b) = talus::generate::hopper_meshes();
            for (m, name) in [(h, "hopper.stl"), (b, "box.stl")] {
                let p = dir.join(name);
                m.write_stl(&p).map_err(|e| TalusError::io(format!("writing {}", p.display()), e))?;
                println!("wrote {}", p.display());
            }
            Ok(ExitCode::SUCCESS)
        }
        Cmd::Cloud { case, out, restart, sets } => {
            let c = Case::load_with(&case, &sets)?;
            let mut sim = talus::sim::Simulation::new(c)?;
            if let Some(ck) = &restart {
                talus::checkpoint::read(&mut sim, ck)?;
            }
            let inits = sim.particles().to_inits();
            talus::generate::write_csv(&out, &inits).map_err(|e| TalusError::io(format!("writing {}", out.display()), e))?;
            println!("wrote {} particles to {}", inits.len(), out.display());
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// A thread count on the command line: a whole number, at least 1.
fn at_least_one(v: &str) -> Result<usize, String> {
    match v.parse::<usize>() {
        Ok(n) if n >= 1 => Ok(n),
        _ => Err(format!("`{v}` is not a thread count (a whole number, at least 1)")),
    }
}
