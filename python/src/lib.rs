//! `talus._talus`: the engine as a Python extension module (pyo3). The
//! package `talus` (python/talus/__init__.py) re-exports it; the stub
//! `_talus.pyi` documents every item for editors.
//!
//! A `Simulation` holds the engine's `Simulation` and a `Runner`
//! (`talus::run`), the same driver as `talus run`: stepping from Python makes
//! the same steps, observers and phase ends as the command line, so the same
//! case gives the same `state_hash`. Stepping releases the GIL in chunks of
//! at most `CHUNK` of wall time; between chunks it checks for signals (Ctrl-C
//! raises `KeyboardInterrupt` between two steps) and calls the callbacks that
//! are due.
//!
//! The module is serial (the cargo feature `mpi` is off): each process runs
//! the whole case on its own threads.

use numpy::ndarray::Array2;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLike1, PyArrayLike2};
use pyo3::create_exception;
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use talus::case::Case;
use talus::dim::Vec3;
use talus::run::Runner;
use talus::sim::ParticleField;
use talus::TalusError;

create_exception!(talus, InputError, PyValueError, "Bad input: a case, a particle file, a mesh or a value set from Python. The message names the file, key or line, and the value (the command line's message).");
create_exception!(talus, RunError, PyRuntimeError, "A run that went wrong (NaN, a particle leaving the domain): the message names the particle and where the failure checkpoint was written.");

/// Longest stretch of stepping without the GIL before signals are checked.
const CHUNK: Duration = Duration::from_millis(100);

fn to_py(e: TalusError) -> PyErr {
    match e {
        TalusError::Input(m) => InputError::new_err(m),
        TalusError::Run(m) => RunError::new_err(m),
        // OSError, or the subclass Python raises for that kind of failure
        TalusError::Io { ref source, .. } => match source.kind() {
            std::io::ErrorKind::NotFound => pyo3::exceptions::PyFileNotFoundError::new_err(e.to_string()),
            std::io::ErrorKind::PermissionDenied => pyo3::exceptions::PyPermissionError::new_err(e.to_string()),
            _ => PyOSError::new_err(e.to_string()),
        },
    }
}

/// A value that is moved into `Python::detach` although it is not `Send`
/// (the engine's `Simulation` holds an `Rc` of its communicator). Sound
/// because `detach` runs its closure on the calling thread and returns before
/// the GIL is taken back: nothing crosses threads.
struct OnThisThread<T>(T);
// SAFETY: see above; the closure runs on the thread that owns the value.
unsafe impl<T> Send for OnThisThread<T> {}

/// A JSON object (a summary) as a Python dict, through the json module.
fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Map<String, serde_json::Value>) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(v).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    py.import("json")?.call_method1("loads", (text,))
}

/// N x 3 float64 array from vectors.
fn vec3s<'py>(py: Python<'py>, v: impl ExactSizeIterator<Item = Vec3>) -> Bound<'py, PyArray2<f64>> {
    let n = v.len();
    let mut flat = Vec::with_capacity(3 * n);
    for x in v {
        flat.extend_from_slice(&[x.x, x.y, x.z]);
    }
    Array2::from_shape_vec((n, 3), flat).expect("n x 3 values").into_pyarray(py)
}

fn path_of(p: &Bound<'_, PyAny>) -> PyResult<PathBuf> {
    p.extract::<PathBuf>()
}

/// Where the summary of the last finished `run` came from.
struct Finished {
    step: u64,
    summary: serde_json::Map<String, serde_json::Value>,
}

/// What a stepping call runs to.
#[derive(Clone, Copy)]
enum Goal {
    /// Until this step count.
    Step(u64),
    /// Until this simulated time (s).
    Time(f64),
    /// Until the phase of this index has ended (or every phase is done).
    PhaseEnd(usize),
    /// Until every phase is done.
    End,
}

/// A talus simulation: a case built into particles and walls, stepped from Python.
///
/// Build one with `Simulation.from_file`, `from_toml`, `from_dict` or
/// `restart`. Stepping (`step`, `run_until`, `run_phase`, `run`) releases the
/// GIL; Ctrl-C raises `KeyboardInterrupt` between two steps and leaves the
/// simulation consistent (call again to go on). Arrays are copies, in order of
/// particle id.
#[pyclass(unsendable, module = "talus")]
pub struct Simulation {
    sim: talus::sim::Simulation,
    runner: Option<Runner>,
    /// (every n steps, function), in the order they were added.
    callbacks: Vec<(u64, Py<PyAny>)>,
    last: Option<Finished>,
    /// Where a failure checkpoint goes when the run writes no outputs.
    fail_dir: PathBuf,
}

impl Simulation {
    fn build(case: Case) -> PyResult<Simulation> {
        let name = case.path.file_stem().map(|s| s.to_os_string()).unwrap_or_else(|| "case".into());
        let fail_dir = PathBuf::from("out").join(name);
        let mut sim = talus::sim::Simulation::new(case).map_err(to_py)?;
        // `fields` may be asked for at any time: the contact stress needs every wall contact
        sim.keep_wall_contacts();
        Ok(Simulation { sim, runner: None, callbacks: Vec::new(), last: None, fail_dir })
    }

    fn ensure_runner(&mut self) -> Result<&mut Runner, TalusError> {
        if self.runner.is_none() {
            self.runner = Some(Runner::start(&mut self.sim, None, &self.fail_dir, false)?);
        }
        Ok(self.runner.as_mut().expect("just started"))
    }

    /// Storage indices of the owned particles in order of id.
    fn by_id(&self) -> Vec<usize> {
        let p = self.sim.particles();
        let mut idx: Vec<usize> = (0..p.owned()).collect();
        idx.sort_unstable_by_key(|&i| p.id[i]);
        idx
    }

    fn array3<'py>(&self, py: Python<'py>, f: impl Fn(usize) -> Vec3) -> Bound<'py, PyArray2<f64>> {
        vec3s(py, self.by_id().into_iter().map(f))
    }

    fn array1<'py, T: numpy::Element + Copy>(&self, py: Python<'py>, f: impl Fn(usize) -> T) -> Bound<'py, PyArray1<T>> {
        self.by_id().into_iter().map(f).collect::<Vec<T>>().into_pyarray(py)
    }

    /// Steps without the GIL towards `goal`, for at most `CHUNK` of wall time
    /// or until a callback is due. Returns whether the goal was reached and
    /// whether any step was made.
    fn chunk(&mut self, goal: Goal, due: &[u64]) -> Result<(bool, bool), TalusError> {
        let start = Instant::now();
        let first = self.sim.step_count();
        self.ensure_runner()?;
        let (runner, sim) = (self.runner.as_mut().expect("a runner"), &mut self.sim);
        let reached = |sim: &talus::sim::Simulation| match goal {
            Goal::Step(n) => sim.step_count() >= n,
            Goal::Time(t) => sim.time() >= t - 0.5 * sim.dt(),
            // decided by `end_of_phase` before each step
            Goal::PhaseEnd(_) | Goal::End => false,
        };
        loop {
            let stepped = sim.step_count() > first;
            if reached(sim) {
                return Ok((true, stepped));
            }
            // each step as in `talus run`: the phase's end first, then the step
            let more = runner.end_of_phase(sim)?;
            match goal {
                Goal::PhaseEnd(p) if sim.phase() != p || !more => return Ok((true, stepped)),
                Goal::End if !more => return Ok((true, stepped)),
                _ => {}
            }
            runner.step(sim)?;
            let s = sim.step_count();
            if due.iter().any(|&n| s % n == 0) || start.elapsed() >= CHUNK {
                return Ok((reached(sim), true));
            }
        }
    }

    /// Step towards `goal`: chunks without the GIL, signals and due callbacks between them.
    fn drive(slf: &Bound<'_, Self>, goal: Goal) -> PyResult<()> {
        let py = slf.py();
        loop {
            let (reached, stepped) = {
                let mut guard = slf.try_borrow_mut()?;
                let me: &mut Simulation = &mut guard;
                let due: Vec<u64> = me.callbacks.iter().map(|c| c.0).collect();
                let job = OnThisThread(me);
                let r = py.detach(move || {
                    let job = job;
                    OnThisThread(job.0.chunk(goal, &due))
                });
                r.0.map_err(to_py)?
            };
            py.check_signals()?;
            // callbacks due at this step, in the order they were added
            let calls: Vec<Py<PyAny>> = {
                let me = slf.try_borrow()?;
                let s = me.sim.step_count();
                me.callbacks.iter().filter(|c| s % c.0 == 0).map(|c| c.1.clone_ref(py)).collect()
            };
            if stepped {
                for f in calls {
                    f.call1(py, (slf,))?;
                }
            }
            if reached {
                return Ok(());
            }
        }
    }
}

#[pymethods]
impl Simulation {
    /// Build a simulation from a case file (TOML), with the command line's
    /// validation. `threads`: threads of the run (default: the cores
    /// available); `overrides`: values to change, as `talus run --set`
    /// (`["material[0].friction=0.3", "wall.gate.velocity=[0,0,-0.1]"]`).
    /// Raises InputError with the command line's message.
    #[staticmethod]
    #[pyo3(signature = (path, threads=None, overrides=None))]
    fn from_file(path: &Bound<'_, PyAny>, threads: Option<usize>, overrides: Option<Vec<String>>) -> PyResult<Simulation> {
        let path = path_of(path)?;
        let mut sets = overrides.unwrap_or_default();
        if let Some(t) = threads {
            sets.push(format!("parallel.threads={t}"));
        }
        Simulation::build(Case::load_with(&path, &sets).map_err(to_py)?)
    }

    /// Build a simulation from the text of a case (TOML). Files the case names
    /// (meshes, particle CSV) are found relative to `base_dir`; messages name
    /// the case as `<base_dir>/<name>.toml`.
    #[staticmethod]
    #[pyo3(signature = (text, base_dir=None, name="case", threads=None, overrides=None))]
    fn from_toml(
        text: &str,
        base_dir: Option<&Bound<'_, PyAny>>,
        name: &str,
        threads: Option<usize>,
        overrides: Option<Vec<String>>,
    ) -> PyResult<Simulation> {
        let dir = base_dir.map(path_of).transpose()?.unwrap_or_else(|| PathBuf::from("."));
        let path = dir.join(format!("{name}.toml"));
        let mut sets = overrides.unwrap_or_default();
        if let Some(t) = threads {
            sets.push(format!("parallel.threads={t}"));
        }
        Simulation::build(Case::parse_with(text, &path, &sets).map_err(to_py)?)
    }

    /// Build a simulation from a dict laid out as a case file (`{"simulation":
    /// {...}, "material": [{...}], "wall": [...], "phase": [...]}`); the same
    /// keys, defaults and validation as TOML.
    #[staticmethod]
    #[pyo3(signature = (d, base_dir=None, name="case", threads=None))]
    fn from_dict(
        py: Python<'_>,
        d: &Bound<'_, PyDict>,
        base_dir: Option<&Bound<'_, PyAny>>,
        name: &str,
        threads: Option<usize>,
    ) -> PyResult<Simulation> {
        let json: String = py.import("json")?.call_method1("dumps", (d,))?.extract()?;
        let v: serde_json::Value = serde_json::from_str(&json).map_err(|e| InputError::new_err(format!("case dict: {e}")))?;
        let t = toml::Value::try_from(&v).map_err(|e| InputError::new_err(format!("case dict: cannot be a case: {e} (None values are not allowed)")))?;
        let text = toml::to_string(&t).map_err(|e| InputError::new_err(format!("case dict: {e}")))?;
        Simulation::from_toml(&text, base_dir, name, threads, None)
    }

    /// Continue from a checkpoint written by a run of the same case (`case`:
    /// the case file, or a Simulation built from it).
    #[staticmethod]
    #[pyo3(signature = (checkpoint, case, threads=None))]
    fn restart(checkpoint: &Bound<'_, PyAny>, case: &Bound<'_, PyAny>, threads: Option<usize>) -> PyResult<Simulation> {
        let ck = path_of(checkpoint)?;
        let mut sim = if let Ok(other) = case.cast::<Simulation>() {
            let mut c = other.try_borrow()?.sim.case().clone();
            if let Some(t) = threads {
                c.parallel.threads = Some(t);
            }
            Simulation::build(c)?
        } else {
            Simulation::from_file(case, threads, None)?
        };
        talus::checkpoint::read(&mut sim.sim, &ck).map_err(to_py)?;
        Ok(sim)
    }

    /// Advance `n` time steps (phase ends are applied as in a run; stepping
    /// goes on after the last phase).
    #[pyo3(signature = (n=1))]
    fn step(slf: &Bound<'_, Self>, n: i64) -> PyResult<()> {
        if n < 0 {
            return Err(InputError::new_err(format!("step(n = {n}): n must be 0 or more")));
        }
        let target = slf.try_borrow()?.sim.step_count() + n as u64;
        Simulation::drive(slf, Goal::Step(target))
    }

    /// Step until the simulated time reaches `t` (s), to the nearest step.
    fn run_until(slf: &Bound<'_, Self>, t: f64) -> PyResult<()> {
        if !t.is_finite() {
            return Err(InputError::new_err(format!("run_until(t = {t}): t must be finite")));
        }
        Simulation::drive(slf, Goal::Time(t))
    }

    /// Step until the current phase ends (its end actions applied, such as
    /// walls removed); returns the name of the phase that ended, or None if
    /// every phase was already done.
    fn run_phase(slf: &Bound<'_, Self>) -> PyResult<Option<String>> {
        let (p, name) = {
            let me = slf.try_borrow()?;
            (me.sim.phase(), me.sim.case().phases.get(me.sim.phase()).map(|ph| ph.name.clone()))
        };
        if name.is_none() {
            return Ok(None);
        }
        Simulation::drive(slf, Goal::PhaseEnd(p))?;
        Ok(name)
    }

    /// Run every remaining phase. With `out`, write the same files as `talus
    /// run --out` (probes.csv, snapshots, checkpoints, summary.json), also
    /// when the simulation was stepped before (the series go on from the
    /// current step). Returns the summary (as `summary()`).
    #[pyo3(signature = (out=None, progress=false))]
    fn run<'py>(slf: &Bound<'py, Self>, out: Option<&Bound<'py, PyAny>>, progress: bool) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        let out = out.map(path_of).transpose()?;
        {
            let mut me = slf.try_borrow_mut()?;
            let me = &mut *me;
            let same = me.runner.as_ref().is_some_and(|r| r.out() == out.as_deref());
            if !same {
                let fail = out.clone().unwrap_or_else(|| me.fail_dir.clone());
                me.runner = Some(Runner::start(&mut me.sim, out.as_deref(), &fail, progress).map_err(to_py)?);
            }
        }
        Simulation::drive(slf, Goal::End)?;
        let mut me = slf.try_borrow_mut()?;
        let me = &mut *me;
        let mut runner = me.runner.take().expect("a runner after drive");
        let summary = runner.finish(&mut me.sim).map_err(to_py)?;
        me.last = Some(Finished { step: me.sim.step_count(), summary });
        json_to_py(py, &me.last.as_ref().expect("just set").summary)
    }

    /// The run's summary as a dict (the keys of summary.json): the case's
    /// analysis figures, counts, times, throughput, the state hash. After
    /// `run`, that run's summary; otherwise the figures so far.
    fn summary<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        if let Some(f) = &self.last {
            if f.step == self.sim.step_count() {
                return json_to_py(py, &f.summary);
            }
        }
        self.ensure_runner().map_err(to_py)?;
        let runner = self.runner.as_mut().expect("a runner");
        let s = runner.summary(&mut self.sim).map_err(to_py)?;
        json_to_py(py, &s)
    }

    /// Continuum fields of the present state (coarse-grained; as `talus
    /// fields` computes from one snapshot): a dict of numpy arrays, one row
    /// per point: "at" (m, P x 3), "density" (kg/m^3, P), "velocity" (m/s,
    /// P x 3), "stress", "kinetic_stress", "contact_stress" (Pa, P x 3 x 3,
    /// compression positive; [a, b] is the force's a component times the
    /// branch's b component). `profile="x"|"y"|"z"` (with `points`, default
    /// 100) averages over the other two axes; `grid=(nx, ny, nz)` gives the
    /// cell centres, x fastest. `kernel`: "gauss" (width: standard deviation,
    /// cut off at 3 widths) or "lucy" (width: radius).
    #[pyo3(signature = (width, kernel="gauss", profile=None, grid=None, points=None))]
    fn fields<'py>(
        &self,
        py: Python<'py>,
        width: f64,
        kernel: &str,
        profile: Option<&str>,
        grid: Option<[usize; 3]>,
        points: Option<usize>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let (k, pts) = talus::fields::plan(kernel, width, profile, grid, points)
            .map_err(|(key, v, why)| InputError::new_err(format!("fields({key} = {v}): {why}")))?;
        let f = self.sim.fields_now(k, pts).map_err(to_py)?;
        let n = f.density.len();
        let d = PyDict::new(py);
        d.set_item("at", vec3s(py, f.at.iter().copied()))?;
        d.set_item("density", f.density.clone().into_pyarray(py))?;
        d.set_item("velocity", vec3s(py, f.velocity.iter().copied()))?;
        let tensor = |get: &dyn Fn(usize, usize) -> f64| -> Vec<f64> { (0..n).flat_map(|i| (0..9).map(move |q| (i, q))).map(|(i, q)| get(i, q)).collect() };
        for (name, data) in [
            ("stress", tensor(&|i, q| f.kinetic[i][q] + f.contact[i][q])),
            ("kinetic_stress", tensor(&|i, q| f.kinetic[i][q])),
            ("contact_stress", tensor(&|i, q| f.contact[i][q])),
        ] {
            let a = numpy::ndarray::Array3::from_shape_vec((n, 3, 3), data).expect("n x 3 x 3");
            d.set_item(name, a.into_pyarray(py))?;
        }
        Ok(d)
    }

    /// Hash of every particle's id, position, velocity and spin (hex string):
    /// the same as `talus run` reports for the same state.
    fn state_hash(&self) -> String {
        self.sim.state_hash()
    }

    /// Write a checkpoint (replaced atomically); `Simulation.restart(path,
    /// case)` continues from it as the run would have.
    fn save_checkpoint(&self, path: &Bound<'_, PyAny>) -> PyResult<()> {
        let p = path_of(path)?;
        talus::checkpoint::write(&self.sim, &p).map_err(to_py)
    }

    /// Call `fn(sim)` after every `n_steps` steps (when the step count is a
    /// multiple of it) during `step`, `run_until`, `run_phase` and `run`.
    /// An exception in `fn` stops the stepping and propagates.
    fn every(&mut self, n_steps: i64, r#fn: Py<PyAny>) -> PyResult<()> {
        if n_steps < 1 {
            return Err(InputError::new_err(format!("every(n_steps = {n_steps}): n_steps must be 1 or more")));
        }
        self.callbacks.push((n_steps as u64, r#fn));
        Ok(())
    }

    /// Remove every callback added by `every`.
    fn clear_callbacks(&mut self) {
        self.callbacks.clear();
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.sim.time()
    }

    /// Steps made since the start of the case.
    #[getter]
    fn step_count(&self) -> u64 {
        self.sim.step_count()
    }

    /// Name of the current phase ("end" after the last).
    #[getter]
    fn phase(&self) -> String {
        self.sim.phase_name().to_string()
    }

    /// Index of the current phase (the number of phases after the last).
    #[getter]
    fn phase_index(&self) -> usize {
        self.sim.phase()
    }

    /// The time step (s).
    #[getter]
    fn dt(&self) -> f64 {
        self.sim.dt()
    }

    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> u64 {
        self.sim.particle_count()
    }

    /// Kinetic energy of the particles, translational and rotational (J).
    #[getter]
    fn kinetic_energy(&self) -> f64 {
        self.sim.kinetic_energy()
    }

    /// Particle-particle and particle-wall contacts at the last step.
    #[getter]
    fn contacts(&self) -> u64 {
        self.sim.contacts()
    }

    /// Particle ids (uint64), ascending: the row order of every array.
    #[getter]
    fn ids<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u64>> {
        let p = self.sim.particles();
        self.array1(py, |i| p.id[i])
    }

    /// Positions (m), N x 3 float64, a copy.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = self.sim.particles();
        self.array3(py, |i| p.pos[i])
    }

    /// Velocities (m/s), N x 3 float64, a copy.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = self.sim.particles();
        self.array3(py, |i| p.vel[i])
    }

    /// Angular velocities (rad/s), N x 3 float64, a copy.
    #[getter]
    fn spins<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = self.sim.particles();
        self.array3(py, |i| p.omega[i])
    }

    /// Radii (m; an ellipse's semi-major axis), float64, a copy.
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let p = self.sim.particles();
        self.array1(py, |i| p.radius[i])
    }

    /// Masses (kg), float64, a copy.
    #[getter]
    fn masses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let p = self.sim.particles();
        self.array1(py, |i| p.mass[i])
    }

    /// Total force on each particle at the last step, gravity included (N), N x 3, a copy.
    #[getter]
    fn forces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = self.sim.particles();
        self.array3(py, |i| p.force[i])
    }

    /// Torque on each particle at the last step (N m), N x 3, a copy.
    #[getter]
    fn torques<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let p = self.sim.particles();
        self.array3(py, |i| p.torque[i])
    }

    /// Set the positions (m) of the particles `ids` (N ids, N x 3 values; all
    /// or none): finite and inside the domain, else InputError. The neighbour
    /// lists are rebuilt at the next step.
    fn set_positions(&mut self, ids: PyArrayLike1<'_, i64, AllowTypeChange>, values: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        self.set(ParticleField::Position, ids, values)
    }

    /// Set the velocities (m/s) of the particles `ids`; finite, else InputError.
    fn set_velocities(&mut self, ids: PyArrayLike1<'_, i64, AllowTypeChange>, values: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        self.set(ParticleField::Velocity, ids, values)
    }

    /// Set the angular velocities (rad/s) of the particles `ids`; finite, else InputError.
    fn set_spins(&mut self, ids: PyArrayLike1<'_, i64, AllowTypeChange>, values: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        self.set(ParticleField::Spin, ids, values)
    }

    /// The walls by name: `sim.walls["gate"]`.
    #[getter]
    fn walls(slf: &Bound<'_, Self>) -> Walls {
        Walls { sim: slf.clone().unbind() }
    }

    fn __repr__(&self) -> String {
        format!(
            "<talus.Simulation {}: {} particles, step {}, t = {:.6e} s, phase {}>",
            self.sim.case().path.display(),
            self.sim.particle_count(),
            self.sim.step_count(),
            self.sim.time(),
            self.sim.phase_name()
        )
    }
}

impl Simulation {
    fn set(&mut self, field: ParticleField, ids: PyArrayLike1<'_, i64, AllowTypeChange>, values: PyArrayLike2<'_, f64, AllowTypeChange>) -> PyResult<()> {
        let ids = ids.as_array();
        let values = values.as_array();
        if values.ncols() != 3 {
            return Err(InputError::new_err(format!("set_{}s: values must be N x 3, not N x {}", field.name(), values.ncols())));
        }
        let mut idv = Vec::with_capacity(ids.len());
        for &id in ids.iter() {
            if id < 0 {
                return Err(InputError::new_err(format!("{} of particle {id}: there is no particle {id}", field.name())));
            }
            idv.push(id as u64);
        }
        let vals: Vec<Vec3> = values.rows().into_iter().map(|r| Vec3::new(r[0], r[1], r[2])).collect();
        self.sim.set_particles(field, &idv, &vals).map_err(to_py)
    }
}

/// The walls of a simulation, by name (a mapping: `walls["gate"]`, `len`,
/// iteration over the names, `in`).
#[pyclass(module = "talus")]
pub struct Walls {
    sim: Py<Simulation>,
}

#[pymethods]
impl Walls {
    fn __getitem__(&self, py: Python<'_>, name: &str) -> PyResult<Wall> {
        let s = self.sim.bind(py).try_borrow()?;
        match s.sim.wall_index(name) {
            Some(index) => Ok(Wall { sim: self.sim.clone_ref(py), index }),
            None => {
                let names: Vec<&str> = s.sim.walls().iter().map(|w| w.name.as_str()).collect();
                Err(pyo3::exceptions::PyKeyError::new_err(format!("no wall named {name:?}; the walls are {names:?}")))
            }
        }
    }

    fn __len__(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.sim.bind(py).try_borrow()?.sim.walls().len())
    }

    fn __contains__(&self, py: Python<'_>, name: &str) -> PyResult<bool> {
        Ok(self.sim.bind(py).try_borrow()?.sim.wall_index(name).is_some())
    }

    fn __iter__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let names = self.keys(py)?;
        Ok(PyList::new(py, names)?.as_any().try_iter()?.into_any())
    }

    /// The wall names, in the case's order.
    fn keys(&self, py: Python<'_>) -> PyResult<Vec<String>> {
        Ok(self.sim.bind(py).try_borrow()?.sim.walls().iter().map(|w| w.name.clone()).collect())
    }
}

/// One wall of a simulation (`sim.walls[name]`): its load at the last step,
/// its velocity (settable), whether it still acts, `remove()`.
#[pyclass(module = "talus")]
pub struct Wall {
    sim: Py<Simulation>,
    index: usize,
}

#[pymethods]
impl Wall {
    /// The wall's name.
    #[getter]
    fn name(&self, py: Python<'_>) -> PyResult<String> {
        Ok(self.sim.bind(py).try_borrow()?.sim.walls()[self.index].name.clone())
    }

    /// Force of the particles on the wall at the last step (N), a 3-array.
    #[getter]
    fn force<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let f = self.sim.bind(py).try_borrow()?.sim.walls()[self.index].force;
        Ok(vec![f.x, f.y, f.z].into_pyarray(py))
    }

    /// Torque of the particles on the wall about the origin at the last step (N m), a 3-array.
    #[getter]
    fn torque<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let t = self.sim.bind(py).try_borrow()?.sim.walls()[self.index].torque;
        Ok(vec![t.x, t.y, t.z].into_pyarray(py))
    }

    /// Whether the wall still acts (False once removed).
    #[getter]
    fn active(&self, py: Python<'_>) -> PyResult<bool> {
        Ok(self.sim.bind(py).try_borrow()?.sim.walls()[self.index].active)
    }

    /// The wall's prescribed velocity (m/s), a 3-array; set it to move the wall from the next step on.
    #[getter]
    fn velocity<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let v = self.sim.bind(py).try_borrow()?.sim.walls()[self.index].velocity;
        Ok(vec![v.x, v.y, v.z].into_pyarray(py))
    }

    #[setter]
    fn set_velocity(&self, py: Python<'_>, v: PyArrayLike1<'_, f64, AllowTypeChange>) -> PyResult<()> {
        let v = v.as_array();
        let mut s = self.sim.bind(py).try_borrow_mut()?;
        let name = s.sim.walls()[self.index].name.clone();
        if v.len() != 3 || !v.iter().all(|x| x.is_finite()) {
            return Err(InputError::new_err(format!("wall {name:?} velocity = {v}: must be 3 finite numbers (m/s)")));
        }
        s.sim.set_wall_velocity(self.index, Vec3::new(v[0], v[1], v[2]));
        Ok(())
    }

    /// Torque of the particles on the wall about its rotation axis at the last step (N m),
    /// or None for a wall that never turns.
    #[getter]
    fn axis_torque(&self, py: Python<'_>) -> PyResult<Option<f64>> {
        Ok(self.sim.bind(py).try_borrow()?.sim.walls()[self.index].axis_torque())
    }

    /// The wall's angular velocity about its axis (rad/s), or None for a wall that never
    /// turns; set it to change the rate from the next step on (the axis stays).
    #[getter]
    fn angular_velocity(&self, py: Python<'_>) -> PyResult<Option<f64>> {
        Ok(self.sim.bind(py).try_borrow()?.sim.walls()[self.index].rotation.as_ref().map(|r| r.rate))
    }

    #[setter]
    fn set_angular_velocity(&self, py: Python<'_>, rate: f64) -> PyResult<()> {
        let mut s = self.sim.bind(py).try_borrow_mut()?;
        let name = s.sim.walls()[self.index].name.clone();
        if !rate.is_finite() {
            return Err(InputError::new_err(format!("wall {name:?} angular_velocity = {rate}: must be a finite number (rad/s)")));
        }
        s.sim.set_wall_rate(self.index, rate).map_err(|e| InputError::new_err(e.to_string()))
    }

    /// Remove the wall: it stops acting from the next step on (as a phase's `remove_walls_at_end`).
    fn remove(&self, py: Python<'_>) -> PyResult<()> {
        self.sim.bind(py).try_borrow_mut()?.sim.remove_wall(self.index);
        Ok(())
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let s = self.sim.bind(py).try_borrow()?;
        let w = &s.sim.walls()[self.index];
        Ok(format!("<talus.Wall {:?}: force [{:.6e}, {:.6e}, {:.6e}] N, {}>", w.name, w.force.x, w.force.y, w.force.z, if w.active { "active" } else { "removed" }))
    }
}

/// Run a drag case (the drag paper's study) over its seeded beds into `out`
/// (default out/drag/<id>); returns its summary as a dict. Releases the GIL;
/// Ctrl-C raises KeyboardInterrupt after the bed being run.
#[pyfunction]
#[pyo3(signature = (case, out=None))]
fn drag<'py>(py: Python<'py>, case: &Bound<'py, PyAny>, out: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyAny>> {
    let path = path_of(case)?;
    let dc = talus::drag::DragCase::load(&path).map_err(to_py)?;
    let out = out.map(path_of).transpose()?.unwrap_or_else(|| Path::new("out").join("drag").join(&dc.drag.id));
    // Ctrl-C is checked after each bed (the GIL is taken back for it)
    let interrupted: std::cell::RefCell<Option<PyErr>> = std::cell::RefCell::new(None);
    let job = OnThisThread((&dc, out.as_path(), &interrupted));
    let r = py.detach(move || {
        let job = job;
        let (dc, out, interrupted) = job.0;
        OnThisThread(talus::drag::run_with(dc, out, || {
            Python::attach(|py| py.check_signals()).map_err(|e| {
                *interrupted.borrow_mut() = Some(e);
                TalusError::Run("interrupted".into())
            })
        }))
    });
    if let Some(e) = interrupted.into_inner() {
        return Err(e);
    }
    let s = r.0.map_err(to_py)?;
    json_to_py(py, &s)
}

/// The initial particles of a case (lattice, list or CSV), as a dict of
/// arrays in order of id: ids, positions, velocities, spins, radii, masses.
#[pyfunction]
fn cloud<'py>(py: Python<'py>, case: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyDict>> {
    let path = path_of(case)?;
    let c = Case::load(&path).map_err(to_py)?;
    let s = Simulation::build(c)?;
    let d = PyDict::new(py);
    let p = s.sim.particles();
    d.set_item("ids", s.array1(py, |i| p.id[i]))?;
    d.set_item("positions", s.array3(py, |i| p.pos[i]))?;
    d.set_item("velocities", s.array3(py, |i| p.vel[i]))?;
    d.set_item("spins", s.array3(py, |i| p.omega[i]))?;
    d.set_item("radii", s.array1(py, |i| p.radius[i]))?;
    d.set_item("masses", s.array1(py, |i| p.mass[i]))?;
    Ok(d)
}

#[pymodule]
fn _talus(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Simulation>()?;
    m.add_class::<Walls>()?;
    m.add_class::<Wall>()?;
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add("RunError", m.py().get_type::<RunError>())?;
    m.add_function(wrap_pyfunction!(drag, m)?)?;
    m.add_function(wrap_pyfunction!(cloud, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    // the module is serial: each process runs the whole case
    m.add("mpi", false)?;
    Ok(())
}
