//! A simulation: settings derived once from the case, and the state that a
//! checkpoint saves. The time step, in order:
//!
//! 1. integrator first half (Verlet: half kick + drift; Gear: predict);
//! 2. walls move as prescribed (servo, translation, oscillation, rotation);
//! 3. neighbour lists are checked (domain, NaN) and rebuilt if the two particles
//!    that moved most (or the one that moved most and the walls) moved more than
//!    the skin between them;
//! 4. forces: gravity, then each particle's pair forces in order of its
//!    partners' ids, higher ids (its row) then lower (rows evaluated in any
//!    order, on the rank's threads), then its walls in order;
//! 5. integrator second half (Verlet: half kick; Gear: correct);
//! 6. time advances. The driver then calls its observers (analysis, probes, ...,
//!    `crate::observe`) and checks the phase end conditions (`advance_phase`).
//!
//! The fields are private: the driver, the observers, the drag study and the
//! tests read through accessors (`state`, `particles`, `walls`, `time`, ...) and
//! change the run only through the few named methods below.

use crate::analysis::Analysis;
use crate::case::{Case, ParticleEntry, ParticleSource, TimeStep, WallShape};
use crate::checks;
use crate::clump::Clumps;
use crate::dim::{Dimension, Vec3};
use crate::error::TalusError;
use crate::forces::{compute_forces, SweepSettings};
use crate::generate;
use crate::integrate::{self, GearState, IntegratorKind};
use crate::material::PairTable;
use crate::neighbor::{Carry, Domain, History, Moved, NeighborList};
use crate::fixed::{from_fixed, to_fixed};
use crate::parallel::comm::Comm;
use crate::parallel::decomp::{choose_grid, Decomposition};
use crate::parallel::{BalanceSettings, Parallel};
use crate::particles::{ParticleInit, Particles, Record};
use std::rc::Rc;
use std::time::Instant;
use crate::walls::{Disc, Mesh, Plane, Segments, Shape, Wall};
use serde::{Deserialize, Serialize};

/// Settings fixed for a run, derived from the case.
#[derive(Clone, Debug)]
pub struct Settings {
    pub dt: f64,
    pub dim: Dimension,
    pub sweep: SweepSettings,
    pub integrator: IntegratorKind,
    pub domain: Domain,
    pub rayleigh_time: f64,
}

/// Everything that evolves; a checkpoint is this, serialised.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct State {
    pub p: Particles,
    pub walls: Vec<Wall>,
    pub nl: NeighborList,
    pub gear: GearState,
    pub time: f64,
    pub step: u64,
    pub phase: usize,
    pub phase_start: f64,
    /// Time at which the current phase ends because it has settled.
    pub settle_end: Option<f64>,
    /// Potential energy at the start of the run (J).
    pub pe0: f64,
    pub forces_ready: bool,
    pub contacts: usize,
    pub analysis: Analysis,
    /// Rigid clumps (dumbbells), serial 2D runs.
    #[serde(default)]
    pub clumps: Clumps,
    /// What each `[[phase.insert]]` has inserted, and the next free id.
    #[serde(default)]
    pub inserts: crate::insert::Insertions,
}

pub struct Simulation {
    case: Case,
    set: Settings,
    table: PairTable,
    state: State,
    /// Decomposition, ghosts, migration, balancing (one box when serial).
    par: Parallel,
    /// Global kinetic and potential energy at the last settle check (J).
    energies: (f64, f64),
    /// The first step at whose list rebuild the storage order is remade.
    next_reorder: u64,
    /// This rank's threads (the force sweep runs on them).
    pool: std::sync::Arc<rayon::ThreadPool>,
    /// A batch of inserted particles waits for the next list rebuild.
    insert_pending: bool,
    /// The particles inserted since the run's observers last took them.
    inserted_log: Vec<crate::insert::Inserted>,
    /// Keep every wall contact at every force sweep (`keep_wall_contacts`).
    keep_walls: bool,
    /// Keep the wall contacts of the next step's sweep (an output is due after it).
    walls_wanted: bool,
}

/// The fewest owned particles whose integrator halves run on the rank's
/// threads. A half step costs a few nanoseconds a particle, and handing work
/// to the pool and back costs tens of microseconds on this machine (its
/// threads sleep between steps): H1-small (5,000 spheres) spent 0.86 s
/// integrating on one thread and 2.09 s on two.
const INTEGRATE_ON_THREADS: usize = 32_768;

/// Rayleigh time of a sphere: pi R sqrt(rho / G) / (0.1631 nu + 0.8766).
pub fn rayleigh_time(radius: f64, density: f64, shear_modulus: f64, nu: f64) -> f64 {
    std::f64::consts::PI * radius * (density / shear_modulus).sqrt() / (0.1631 * nu + 0.8766)
}

impl Simulation {
    /// Build a serial simulation from a validated case: particles, walls, lists, checks.
    pub fn new(case: Case) -> Result<Simulation, TalusError> {
        Simulation::new_on(case, Rc::new(Comm::Serial))
    }

    /// Build a simulation on a communicator (a collective: every rank calls it
    /// with the same case). Every rank reads the whole input, checks it, then
    /// keeps the particles inside its box of the initial decomposition.
    pub fn new_on(case: Case, comm: Rc<Comm>) -> Result<Simulation, TalusError> {
        let path = case.path.display().to_string();
        // every convention option, resolved in one place
        let opts = crate::contact::conventions::resolve(&case.contact);
        let table = PairTable::for_case(&case, opts.mixing);
        let mut p = build_particles(&case, &comm)?;
        // every rank holds every particle here: inserted ones follow the largest id
        let inserts = crate::insert::Insertions::new(&case, p.id.iter().copied().max().unwrap_or(0) + 1);
        let (dt, tr, rmin) = time_step(&case, &p)?;
        // a batch every step at most: a shorter interval would place empty batches by the million
        for ph in &case.phases {
            for (k, ins) in ph.inserts.iter().enumerate() {
                if let Some(iv) = ins.interval.filter(|&iv| iv < dt) {
                    return Err(TalusError::Input(format!(
                        "{path}: phase.{}.insert[{k}].interval = {iv}: shorter than the time step {dt:.4e} s",
                        ph.name
                    )));
                }
            }
        }
        let mut walls = crate::parallel::agreed(&comm, build_walls(&case))?;
        apply_moves(&mut walls, &case, 0, 0.0);
        let s = &case.simulation;
        let domain = Domain { lo: Vec3::from(s.domain.lo), hi: Vec3::from(s.domain.hi) };
        let period = Vec3::from(s.domain.period());
        let set = Settings {
            dt,
            dim: s.dimension,
            sweep: SweepSettings {
                contact: case.contact.clone(),
                opts,
                gravity: Vec3::from(s.gravity),
                dt,
                grain: usize::MAX,
                period,
                record_walls: case.output.contacts || case.output.fields.is_some(),
            },
            integrator: s.integrator,
            domain,
            rayleigh_time: tr,
        };
        // a law that acts beyond touching (jkr) needs a skin that keeps its
        // contacts in the list to their end: at least twice its longest reach
        let r_max = case
            .phases
            .iter()
            .flat_map(|ph| ph.inserts.iter())
            .map(|ins| match &ins.radius {
                crate::case::RadiusSection::Uniform { max, .. } => *max,
                crate::case::RadiusSection::Discrete { values, .. } => values.iter().cloned().fold(0.0, f64::max),
            })
            .chain(p.radius.iter().copied())
            .fold(0.0, f64::max);
        let reach = crate::contact::longest_reach(&case.contact, &table, r_max);
        let skin = match s.skin {
            Some(skin) if skin < 2.0 * reach => {
                return Err(TalusError::Input(format!(
                    "{path}: simulation.skin = {skin}: the jkr law's contacts pull up to {reach:.4e} m beyond touching; the skin must be at least twice that ({:.4e} m) to keep them in the neighbour list",
                    2.0 * reach
                )))
            }
            Some(skin) => skin,
            None => (0.2 * rmin).max(2.0 * reach),
        };
        let mut nl = NeighborList::new(skin);
        nl.period = period;
        nl.skin_rule = crate::neighbor::SkinRule::new(dt);
        // the second history slot: the rolling spring's torque (epsd2), or the
        // mark of a contact that reaches beyond touching (jkr, `forces::TOUCHING`)
        nl.rolling_history = case.contact.rolling == Some(crate::case::RollingModel::Epsd2) || crate::contact::law_traits(&case.contact).1;
        nl.displacement(&p, &domain).map_err(|e| TalusError::Input(format!("{path}: initial state: {e}")))?;
        nl.build(&p, &walls);
        check_initial_overlaps(&case, &p, &nl)?;
        check_periodic_overlaps(&case, &p, &domain, skin)?;
        checks::wall_overlaps(&case, &p, &walls)?;
        let clumps = build_clumps(&case, &comm, &mut p)?;
        let pe0 = p.potential_energy(set.sweep.gravity);
        let analysis = Analysis::new(&case, &p, &walls)?;
        let mut par = build_parallel(&case, comm, &p, &domain, skin)?;
        if !clumps.is_empty() {
            // a clump holds its members' storage indices: they stay in id order
            par.order = crate::order::StorageOrder::Id;
        }
        let mut gear = GearState::default();
        let mut hist = History::default();
        par.take_own(&mut p, &mut gear, &mut hist);
        let hist = par.migrate(&mut p, &mut gear, hist);
        nl.build_with(&p, &walls, Carry::Keyed(&hist));
        let state = State {
            p,
            walls,
            nl,
            gear,
            time: 0.0,
            step: 0,
            phase: 0,
            phase_start: 0.0,
            settle_end: None,
            pe0,
            forces_ready: false,
            contacts: 0,
            analysis,
            clumps,
            inserts,
        };
        let pool = par.collective(thread_pool(&case, &par))?;
        let mut set = set;
        let mut par = par;
        if pool.current_num_threads() > 1 {
            set.sweep.grain = crate::forces::MIN_LEN;
            par.pool = Some(pool.clone());
        }
        Ok(Simulation { case, set, table, state, par, energies: (0.0, 0.0), next_reorder: 0, pool, insert_pending: false, inserted_log: Vec::new(), keep_walls: false, walls_wanted: false })
    }

    /// Threads this rank computes forces on.
    pub fn threads(&self) -> usize {
        self.pool.current_num_threads()
    }

    /// The case this simulation was built from.
    pub fn case(&self) -> &Case {
        &self.case
    }

    /// Everything that evolves (what a checkpoint saves), read-only.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The parallel runtime: communicator, decomposition, timers (one box when serial).
    pub fn parallel(&self) -> &Parallel {
        &self.par
    }

    /// The time step (s).
    pub fn dt(&self) -> f64 {
        self.set.dt
    }

    /// The Rayleigh time of the smallest particle (s).
    pub fn rayleigh_time(&self) -> f64 {
        self.set.rayleigh_time
    }

    pub fn dimension(&self) -> Dimension {
        self.set.dim
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Steps taken since the start of the run (restarts included).
    pub fn step_count(&self) -> u64 {
        self.state.step
    }

    /// Index of the current phase (the number of phases once all are done).
    pub fn phase(&self) -> usize {
        self.state.phase
    }

    /// This rank's particles: the owned ones first, then the ghosts.
    pub fn particles(&self) -> &Particles {
        &self.state.p
    }

    /// The walls, in the case's order.
    pub fn walls(&self) -> &[Wall] {
        &self.state.walls
    }

    /// Index of the wall called `name`.
    pub fn wall_index(&self, name: &str) -> Option<usize> {
        self.state.walls.iter().position(|w| w.name == name)
    }

    /// Touching contacts on this rank at the last force sweep.
    pub fn local_contacts(&self) -> usize {
        self.state.contacts
    }

    /// The running figures of the case's `[analysis]`.
    pub fn analysis(&self) -> &Analysis {
        &self.state.analysis
    }

    /// The analysis, to record into (its figures are saved in checkpoints).
    pub fn analysis_mut(&mut self) -> &mut Analysis {
        &mut self.state.analysis
    }

    /// The signal (SIGINT, SIGTERM) every rank agreed to stop at, if any.
    pub fn stop_signal(&self) -> Option<i32> {
        self.par.stop
    }

    /// Prescribe wall `i`'s velocity (m/s) from the next step on.
    pub fn set_wall_velocity(&mut self, i: usize, v: Vec3) {
        self.state.walls[i].velocity = v;
    }

    /// Set wall `i`'s rate of turning about its axis (rad/s) from the next step
    /// on; refused for a wall that never turns (it has no axis).
    pub fn set_wall_rate(&mut self, i: usize, rate: f64) -> Result<(), TalusError> {
        let w = &mut self.state.walls[i];
        match &mut w.rotation {
            Some(r) => {
                r.rate = rate;
                Ok(())
            }
            None => Err(TalusError::Input(format!(
                "wall \"{}\" has no rotation axis: give it a `rotation` in the case (angular_velocity 0 to start at rest)",
                w.name
            ))),
        }
    }

    /// Remove wall `i` (as a phase's `remove_walls_at_end` does): it stops
    /// acting from the next step on; its candidates leave the lists at once.
    pub fn remove_wall(&mut self, i: usize) {
        self.state.walls[i].active = false;
        self.state.nl.x_ref.clear();
    }

    /// Set one vector (`field`) of the particles with the given global ids,
    /// all or none: every value finite, a position inside the domain, in 2D no
    /// component the dimension does not allow (z of a position or velocity, x
    /// and y of a spin), no member of a clump, every id a particle of this
    /// rank. With the Gear integrator its predictor takes the new values too.
    /// A changed position rebuilds the lists at the next step; forces are
    /// those of the last step until then.
    pub fn set_particles(&mut self, field: ParticleField, ids: &[u64], values: &[Vec3]) -> Result<(), TalusError> {
        if ids.len() != values.len() {
            return Err(TalusError::Input(format!(
                "{} ids but {} values: one {} a particle",
                ids.len(),
                values.len(),
                field.name()
            )));
        }
        let p = &self.state.p;
        let index: std::collections::HashMap<u64, usize> = (0..p.owned()).map(|i| (p.id[i], i)).collect();
        let (dim, dom) = (self.set.dim, &self.set.domain);
        let mut at = Vec::with_capacity(ids.len());
        for (&id, v) in ids.iter().zip(values) {
            let Some(&i) = index.get(&id) else {
                return Err(TalusError::Input(format!("{} of particle {id}: there is no particle {id}", field.name())));
            };
            let bad = |why: &str| TalusError::Input(format!("{} of particle {id} = [{}, {}, {}]: {why}", field.name(), v.x, v.y, v.z));
            if !v.iter().all(|x| x.is_finite()) {
                return Err(bad("must be finite"));
            }
            let allowed = match field {
                ParticleField::Spin => dim.project_angular(*v),
                _ => dim.project_linear(*v),
            };
            if allowed != *v {
                return Err(bad("a 2D case allows no z of a position or velocity, no x or y of a spin"));
            }
            if field == ParticleField::Position
                && !(v.x >= dom.lo.x && v.y >= dom.lo.y && v.z >= dom.lo.z && v.x <= dom.hi.x && v.y <= dom.hi.y && v.z <= dom.hi.z)
            {
                return Err(bad(&format!(
                    "outside the domain [{}, {}, {}] to [{}, {}, {}]",
                    dom.lo.x, dom.lo.y, dom.lo.z, dom.hi.x, dom.hi.y, dom.hi.z
                )));
            }
            if p.clump[i] != 0 {
                return Err(bad("the particle is a member of a clump, which moves as one rigid body"));
            }
            at.push(i);
        }
        let gear = self.set.integrator == IntegratorKind::Gear && self.state.gear.initialised;
        let dt = self.set.dt;
        let (p, g) = (&mut self.state.p, &mut self.state.gear);
        for (&i, v) in at.iter().zip(values) {
            match field {
                ParticleField::Position => {
                    p.pos[i] = *v;
                    if gear {
                        g.r[0][i] = *v;
                    }
                }
                ParticleField::Velocity => {
                    p.vel[i] = *v;
                    if gear {
                        g.r[1][i] = *v * dt;
                    }
                }
                ParticleField::Spin => {
                    p.omega[i] = *v;
                    if gear {
                        g.w[0][i] = *v;
                    }
                }
            }
        }
        if field == ParticleField::Position {
            self.rebuild_list();
        }
        Ok(())
    }

    /// Add a wall (after the case's); lists are rebuilt at the next step.
    pub fn add_wall(&mut self, w: Wall) {
        self.state.walls.push(w);
        self.state.nl.x_ref.clear();
    }

    /// Set the velocity of the particle at storage index `i` (m/s).
    pub fn set_velocity(&mut self, i: usize, v: Vec3) {
        self.state.p.vel[i] = v;
    }

    /// Turn clump `k` to `angle` (rad) about its centre; lists are rebuilt at the next step.
    pub fn set_clump_angle(&mut self, k: usize, angle: f64) {
        self.state.clumps.angle[k] = angle;
        self.state.clumps.place(&mut self.state.p);
        self.state.nl.x_ref.clear();
    }

    /// Replace the material pair table (for example a frictionless one while a
    /// bed is grown); returns the old one.
    pub fn replace_pair_table(&mut self, t: PairTable) -> PairTable {
        std::mem::replace(&mut self.table, t)
    }

    /// One force sweep at the current positions, nothing else (for benchmarks);
    /// returns the touching contacts on this rank.
    pub fn force_sweep(&mut self) -> usize {
        self.forces();
        self.state.contacts
    }

    /// Continue from a checkpoint's state and contact history: every rank keeps
    /// its own particles of the global state `st` (a collective).
    pub fn restore(&mut self, mut st: State, mut hist: History) {
        self.par.refit_all(&st.p.pos);
        self.par.reorder_now = true;
        self.par.take_own(&mut st.p, &mut st.gear, &mut hist);
        let hist = self.par.migrate(&mut st.p, &mut st.gear, hist);
        st.nl.rolling_history = self.state.nl.rolling_history;
        st.nl.period = self.state.nl.period;
        st.nl.skin_rule = self.state.nl.skin_rule;
        st.nl.skin_limit = st.nl.skin;
        st.nl.build_with(&st.p, &st.walls, Carry::Keyed(&hist));
        self.state = st;
    }

    /// Check the particles and, if any rank needs it, rebuild the lists
    /// (migrating particles and remaking ghosts); else refresh the ghosts.
    /// The particles inserted since the last call (the same on every rank).
    pub fn take_inserted(&mut self) -> Vec<crate::insert::Inserted> {
        std::mem::take(&mut self.inserted_log)
    }

    /// Place the batches of the current phase's insertions that are due (the
    /// same on every rank: see `insert`); each rank keeps those its box owns,
    /// which join at the list rebuild this asks for.
    fn insert_batches(&mut self, mid_step: bool) -> Result<(), TalusError> {
        let Some(ph) = self.case.phases.get(self.state.phase) else { return Ok(()) };
        if ph.inserts.is_empty() {
            return Ok(());
        }
        let st = &mut self.state;
        let elapsed = st.time - st.phase_start;
        let dt = self.set.dt;
        for (k, ins) in ph.inserts.iter().enumerate() {
            loop {
                let pr = &st.inserts.progress[st.phase][k];
                if pr.done || crate::insert::batch_time(ins, pr.batches) > elapsed + 0.5 * dt {
                    break;
                }
                // every particle that may reach into the region, from every rank
                let (lo, hi) = crate::insert::region_box(&ins.region);
                let reach = crate::insert::max_radius(&ins.radius) + st.p.radius[..st.p.owned()].iter().cloned().fold(0.0, f64::max);
                let mine: Vec<(Vec3, f64)> = (0..st.p.owned())
                    .filter(|&i| {
                        let x = st.p.pos[i];
                        // along a periodic axis a particle may reach the region across the face
                        (0..3).all(|a| self.par.period[a] > 0.0 || (x[a] >= lo[a] - reach && x[a] <= hi[a] + reach))
                    })
                    .map(|i| (st.p.pos[i], st.p.radius[i]))
                    .collect();
                let existing = crate::parallel::all_gather(&self.par.comm, &mine);
                let at = format!("{}: phase.{}.insert[{k}]", self.case.path.display(), ph.name);
                let pr = &mut st.inserts.progress[st.phase][k];
                let placed = crate::insert::place_batch(&self.case, &at, ins, pr, &mut st.inserts.next_id, &existing)?;
                if placed.is_empty() {
                    continue;
                }
                let m = self.case.material_index(&ins.material, "insert.material")?;
                let density = self.case.materials[m as usize].density;
                let me = self.par.rank();
                let recs = crate::insert::records(&placed, density, m, self.set.sweep.gravity, dt, mid_step);
                let (step, time) = (st.step, st.time);
                self.inserted_log.extend(placed.iter().map(|p| crate::insert::Inserted { step, time, init: p.clone(), material: m }));
                self.par.inserted.extend(recs.into_iter().filter(|r| self.par.dec.owner(&r.pos) == me));
                self.insert_pending = true;
            }
        }
        Ok(())
    }

    fn refresh_lists(&mut self) -> Result<(), TalusError> {
        let st = &mut self.state;
        let t = Instant::now();
        // on the rank's threads where the list is built on them (`displacement` splits only a large system)
        let moved = if st.nl.threaded {
            let (nl, p, domain) = (&st.nl, &st.p, &self.set.domain);
            self.pool.install(|| nl.displacement(p, domain))
        } else {
            st.nl.displacement(&st.p, &self.set.domain)
        };
        let (moved, err) = match moved {
            Ok(d) => (d, None),
            Err(e) => (Moved::everything(), Some(e.to_string())),
        };
        // a batch of inserted particles joins at a rebuild (every rank knows of it)
        let need = std::mem::replace(&mut self.insert_pending, false);
        let (need, moved, err) = self.par.agree(need || self.par.rebalance_pending, moved, err);
        let need = need || moved.stale(st.nl.skin, st.nl.wall_moved, st.nl.grown);
        self.par.timers.check += t.elapsed().as_secs_f64();
        if let Some(e) = err {
            return Err(TalusError::Run(e));
        }
        let t = Instant::now();
        if need {
            // the storage order is remade at most every `reorder_interval` steps
            self.par.reorder_now = st.step >= self.next_reorder;
            if self.par.reorder_now {
                self.next_reorder = st.step + self.case.parallel.reorder_interval;
            }
            // the skins' limit, before the ghosts are made to cover it (the
            // particles inserted on this rank join at this build too)
            // (a largest speed is the same in any order: the few inserted first)
            let inserted = self.par.inserted.iter().map(|r| r.vel.norm()).fold(0.0, f64::max);
            let p = &st.p;
            let speed = || p.vel[..p.owned()].iter().map(|v| v.norm()).fold(inserted, f64::max);
            st.nl.skin_limit = self.par.skin_limit(&st.nl.skin_rule, st.nl.skin, speed);
            let h = self.par.migrate_from_list(&mut st.p, &mut st.gear, &st.nl);
            // one rank: the list carries its own history
            let carry = h.carry();
            let migrated = t.elapsed().as_secs_f64();
            self.par.timers.migrate += migrated;
            self.par.timers.comm_s += migrated;
            let t2 = Instant::now();
            // the list is built on the rank's threads (a small one, in one block, on this one)
            st.nl.threaded = self.set.sweep.grain != usize::MAX;
            if st.nl.threaded {
                let (nl, p, walls) = (&mut st.nl, &st.p, &st.walls);
                self.pool.install(|| nl.build_with(p, walls, carry));
            } else {
                st.nl.build_with(&st.p, &st.walls, carry);
            }
            self.par.timers.list_build += t2.elapsed().as_secs_f64();
            self.par.rebalance_pending = false;
        } else {
            self.par.update_ghosts(&mut st.p);
            let refreshed = t.elapsed().as_secs_f64();
            self.par.timers.ghost_refresh += refreshed;
            self.par.timers.comm_s += refreshed;
        }
        Ok(())
    }

    /// Run an integrator half `f` on the particles: on the rank's threads, or
    /// on this thread for fewer than `INTEGRATE_ON_THREADS` particles.
    fn on_threads(&mut self, f: impl FnOnce(&mut Particles) + Send) {
        if self.integrate_grain() == usize::MAX {
            f(&mut self.state.p)
        } else {
            let p = &mut self.state.p;
            self.pool.install(|| f(p))
        }
    }

    /// Fewest blocks of particles a thread integrates at once: 1 on several
    /// threads; on one, or for a system too small to gain, nothing is split
    /// and the pool is not used.
    fn integrate_grain(&self) -> usize {
        if self.set.sweep.grain == usize::MAX || self.state.p.owned() < INTEGRATE_ON_THREADS { usize::MAX } else { 1 }
    }

    fn forces(&mut self) {
        let (st, set, table) = (&mut self.state, &self.set, &self.table);
        // a small system runs on this thread (handing it to the pool would cost
        // more than the sweep); a larger one on the rank's threads
        let small = st.p.len().max(st.nl.pairs.len()) <= 2 * crate::forces::MIN_LEN || set.sweep.grain == usize::MAX;
        let c = if small {
            compute_forces(&set.sweep, &mut st.p, &mut st.walls, &mut st.nl, table)
        } else {
            self.pool.install(|| compute_forces(&set.sweep, &mut st.p, &mut st.walls, &mut st.nl, table))
        };
        st.contacts = c.owned;
        self.par.evaluated = c.evaluated;
    }

    /// Sum the walls' loads over ranks (exact, the same for any P).
    fn reduce_walls(&mut self) {
        let t = Instant::now();
        let mut v: Vec<i128> = self.state.walls.iter().flat_map(|w| w.load).collect();
        self.par.comm.sum_exact(&mut v);
        for (w, c) in self.state.walls.iter_mut().zip(v.chunks_exact(6)) {
            w.force = Vec3::new(from_fixed(c[0]), from_fixed(c[1]), from_fixed(c[2]));
            w.torque = Vec3::new(from_fixed(c[3]), from_fixed(c[4]), from_fixed(c[5]));
        }
        let dt = t.elapsed().as_secs_f64();
        self.par.timers.wall_sums += dt;
        self.par.timers.comm_s += dt;
    }

    /// Exact global sums of fixed-point values (a collective).
    #[track_caller]
    pub fn sum_exact(&self, v: &mut [i128]) {
        self.par.comm.sum_exact(v);
    }

    /// Kinetic energy of all particles on all ranks (J; a collective).
    #[track_caller]
    pub fn kinetic_energy(&self) -> f64 {
        let mut v = [self.state.p.kinetic_energy_fixed()];
        self.sum_exact(&mut v);
        from_fixed(v[0])
    }

    /// Touching contacts over all ranks (a collective).
    #[track_caller]
    pub fn contacts(&self) -> u64 {
        let mut v = [self.state.contacts as u64];
        self.par.comm.sum_u64(&mut v);
        v[0]
    }

    /// Total momentum of the particles on all ranks (kg m/s; exact sums, a collective).
    #[track_caller]
    pub fn momentum(&self) -> Vec3 {
        let p = &self.state.p;
        let mut v = [0i128; 3];
        for i in 0..p.owned() {
            for k in 0..3 {
                v[k] += to_fixed(p.mass[i] * p.vel[i][k]);
            }
        }
        self.sum_exact(&mut v);
        Vec3::new(from_fixed(v[0]), from_fixed(v[1]), from_fixed(v[2]))
    }

    /// Particles over all ranks (a collective).
    #[track_caller]
    pub fn particle_count(&self) -> u64 {
        let mut v = [self.state.p.owned() as u64];
        self.par.comm.sum_u64(&mut v);
        v[0]
    }

    /// Mass of the particles with centre below z over all ranks (a collective).
    #[track_caller]
    pub fn mass_below(&self, z: f64) -> f64 {
        let p = &self.state.p;
        let mut v = [(0..p.owned()).filter(|&i| p.pos[i].z < z).map(|i| to_fixed(p.mass[i])).sum::<i128>()];
        self.sum_exact(&mut v);
        from_fixed(v[0])
    }

    /// Every rank's counters (particles, ghosts, contacts, compute and
    /// communication time since the last call, which restarts them; a collective).
    pub fn rank_counters(&mut self) -> Vec<crate::parallel::RankCounters> {
        self.par.gather_counters(&self.state.p)
    }

    /// Full records of the given particles, wherever they are owned (a collective).
    pub fn tracked(&self, ids: &[u64]) -> Vec<Option<Record>> {
        self.par.gather_ids(&self.state.p, ids)
    }

    /// This rank's contacts as the continuum fields' stress needs them:
    /// every touching pair whose lower id it owns and every wall contact of
    /// its particles, at the last force sweep (wall contacts only where they
    /// were kept: [`Simulation::want_wall_contacts`] before the step, or
    /// [`Simulation::keep_wall_contacts`]; the first sweep keeps them where the
    /// case asks for contacts or fields).
    pub fn contact_records(&self) -> Vec<crate::fields::ContactRecord> {
        let (p, nl) = (&self.state.p, &self.state.nl);
        // (the period where the particles carry images, as `Shapes::new` takes it)
        let period = (!p.image.is_empty()).then_some(self.set.sweep.period);
        let n_own = p.owned();
        let zero = crate::forces::zero_slot(&nl.pairs) as usize;
        let mut out = Vec::new();
        for (k, &(a, b)) in nl.pairs.iter().enumerate() {
            let (a, b) = (a as usize, b as usize);
            let slot = nl.pair_slot.get(k).map_or(zero, |&x| x as usize);
            if a >= n_own || slot >= zero {
                continue;
            }
            let d = crate::contact::geometry::pair_offset(p, a, b, period.as_ref());
            let share = p.radius[a] / (p.radius[a] + p.radius[b]);
            out.push(crate::fields::ContactRecord {
                a: p.id[a],
                partner: p.id[b],
                wall: false,
                force: nl.pair_out[slot].force,
                point: p.pos[a] - d * share,
                centre: p.pos[a],
                branch: d,
            });
        }
        for w in &nl.wall_records {
            let i = w.particle as usize;
            out.push(crate::fields::ContactRecord {
                a: p.id[i],
                partner: w.wall as u64,
                wall: true,
                force: w.force,
                point: w.point,
                centre: w.centre,
                branch: w.centre - w.point,
            });
        }
        out
    }

    /// Every rank's contacts ([`Simulation::contact_records`]) on every rank,
    /// in order of (particle, wall or not, partner, point) (a collective).
    pub fn all_contacts(&self) -> Vec<crate::fields::ContactRecord> {
        let mut all = crate::parallel::all_gather(&self.par.comm, &self.contact_records());
        all.sort_by(|x, y| {
            (x.a, x.wall, x.partner)
                .cmp(&(y.a, y.wall, y.partner))
                .then(x.point.x.total_cmp(&y.point.x))
                .then(x.point.y.total_cmp(&y.point.y))
                .then(x.point.z.total_cmp(&y.point.z))
        });
        all
    }

    /// Keep every wall contact of each force sweep from now on (the contact
    /// stress of the continuum fields needs them; a case with
    /// `output.contacts` or `[output.fields]` keeps them from the start).
    pub fn keep_wall_contacts(&mut self) {
        self.keep_walls = true;
        self.set.sweep.record_walls = true;
    }

    /// Keep the wall contacts of the next step's force sweep (an observer
    /// that writes contacts after that step asks for them; keeping them at
    /// every step would cost the sweep a record per wall contact).
    pub fn want_wall_contacts(&mut self) {
        self.walls_wanted = true;
    }

    /// The continuum fields of the present state, one sample (a collective).
    /// Wall contacts count only where they are kept ([`Simulation::keep_wall_contacts`]).
    pub fn fields_now(&self, kernel: crate::fields::kernel::Kernel, points: crate::fields::Points) -> Result<crate::fields::Averaged, TalusError> {
        let mut f = crate::fields::Fields::new(kernel, points, self.fields_domain()).map_err(TalusError::Input)?;
        let (p, contacts) = self.fields_sample();
        f.add(&crate::fields::Sample::of(&p, &contacts));
        Ok(f.averaged())
    }

    /// What one sample of the continuum fields reads: every particle, in
    /// order of id, and every contact ([`Simulation::all_contacts`]), on
    /// every rank (a collective).
    pub fn fields_sample(&self) -> (Particles, Vec<crate::fields::ContactRecord>) {
        let (p, _) = self.par.gather_particles(&self.state.p, &self.state.gear);
        (p, self.all_contacts())
    }

    /// The fields' domain: the case's box and its periodic axes.
    pub fn fields_domain(&self) -> crate::fields::Domain {
        let d = &self.case.simulation.domain;
        crate::fields::Domain { lo: Vec3::from(d.lo), hi: Vec3::from(d.hi), periodic: [d.is_periodic(0), d.is_periodic(1), d.is_periodic(2)] }
    }

    /// Forces at the current state, once before the first step.
    pub fn prepare(&mut self) -> Result<(), TalusError> {
        if !self.state.forces_ready {
            // particles inserted at the start of the first step are there from its start
            self.insert_batches(false)?;
            self.refresh_lists()?;
            self.forces();
            self.reduce_walls();
            if self.set.integrator == IntegratorKind::Gear {
                self.state.gear.init(&self.state.p, self.set.dt, self.set.dim);
            }
            self.state.forces_ready = true;
        }
        Ok(())
    }

    /// Advance one time step.
    pub fn step(&mut self) -> Result<(), TalusError> {
        self.prepare()?;
        self.set.sweep.record_walls = self.keep_walls || std::mem::take(&mut self.walls_wanted);
        let t0 = Instant::now();
        let comm0 = self.par.timers.comm_s;
        let dt = self.set.dt;
        let dim = self.set.dim;
        match self.set.integrator {
            IntegratorKind::Verlet => {
                let grain = self.integrate_grain();
                self.on_threads(|p| integrate::verlet_first(p, dt, dim, grain));
                if !self.state.clumps.is_empty() {
                    self.state.clumps.first_half(&mut self.state.p, dt);
                }
            }
            IntegratorKind::Gear => self.state.gear.predict(&mut self.state.p, dt),
        }
        let dom = &self.set.domain;
        self.par.wrap(&mut self.state.p, &dom.lo, &dom.hi);
        self.par.timers.integrate += t0.elapsed().as_secs_f64();
        let mut moved: f64 = 0.0;
        let t_next = (self.state.step + 1) as f64 * dt;
        for w in &mut self.state.walls {
            if w.active {
                w.servo_update(dt);
            }
            let m = w.advance(dt, t_next);
            if w.active {
                moved = moved.max(m);
            }
        }
        self.state.nl.wall_moved += moved;
        self.insert_batches(true)?;
        self.refresh_lists()?;
        let t1 = Instant::now();
        self.forces();
        let t2 = Instant::now();
        self.par.timers.forces += (t2 - t1).as_secs_f64();
        match self.set.integrator {
            IntegratorKind::Verlet => {
                let grain = self.integrate_grain();
                self.on_threads(|p| integrate::verlet_second(p, dt, dim, grain));
                if !self.state.clumps.is_empty() {
                    self.state.clumps.second_half(&mut self.state.p, dt);
                }
            }
            IntegratorKind::Gear => self.state.gear.correct(&mut self.state.p, dt, dim),
        }
        self.par.timers.integrate += t2.elapsed().as_secs_f64();
        let compute = (t0.elapsed().as_secs_f64() - (self.par.timers.comm_s - comm0)).max(0.0);
        self.par.timers.compute_s += compute;
        self.reduce_walls();
        self.par.after_step(&self.state.p, compute);
        self.state.step += 1;
        self.state.time = self.state.step as f64 * dt;
        // a removed wall stops acting from the next force sweep on (the sweep skips
        // inactive walls; their candidates leave the list at its next rebuild)
        let t = self.state.time;
        for w in &mut self.state.walls {
            if w.active && w.remove_at.is_some_and(|r| t >= r - 0.5 * dt) {
                w.active = false;
            }
        }
        Ok(())
    }

    /// Whether the current phase is over; applies its end actions and moves on if so.
    /// Returns false once every phase is done.
    pub fn advance_phase(&mut self) -> Result<bool, TalusError> {
        let Some(ph) = self.case.phases.get(self.state.phase) else { return Ok(false) };
        if ph.kinetic_energy_fraction.is_some() && self.state.settle_end.is_none() && self.state.step % 20 == 0 {
            // exact global sums: every rank count decides at the same step
            let mut v = [self.state.p.kinetic_energy_fixed(), self.state.p.potential_energy_fixed(self.set.sweep.gravity)];
            self.sum_exact(&mut v);
            self.energies = (from_fixed(v[0]), from_fixed(v[1]));
        }
        let (ke, pe) = self.energies;
        let st = &mut self.state;
        let elapsed = st.time - st.phase_start;
        let dt = self.set.dt;
        let mut done = elapsed >= ph.duration - 0.5 * dt;
        if let Some(frac) = ph.kinetic_energy_fraction {
            if st.settle_end.is_none() && st.step % 20 == 0 {
                let drop = st.pe0 - pe;
                if drop > 0.0 && ke < frac * drop {
                    st.settle_end = Some(st.time + ph.settle_extra);
                }
            }
            if let Some(t) = st.settle_end {
                done |= st.time >= t - 0.5 * dt;
            }
        }
        if done {
            for name in &ph.remove_walls_at_end {
                if let Some(w) = st.walls.iter_mut().find(|w| &w.name == name) {
                    w.active = false;
                }
            }
            st.phase += 1;
            st.phase_start = st.time;
            st.settle_end = None;
            apply_moves(&mut st.walls, &self.case, st.phase, st.time);
        }
        Ok(self.state.phase < self.case.phases.len())
    }

    /// Have the next step build the neighbour list anew. Nothing physical
    /// depends on when the list is built, so this changes speed only (tests
    /// prove so against it).
    pub fn rebuild_list(&mut self) {
        self.state.nl.x_ref.clear();
    }

    /// Set every owned particle's radius to `radius_of(id)` (for an ellipse its
    /// equivalent radius sqrt(a b), the aspect ratio kept), with mass and inertia
    /// from their material's density; the neighbour list is kept where it can be
    /// (`NeighborList::radii_changed`), else rebuilt at the next step.
    /// (Used to compact a bed by growing the granules.)
    pub fn set_radii(&mut self, radius_of: impl Fn(u64) -> f64) {
        let p = &mut self.state.p;
        let mut grown = 0.0f64;
        for i in 0..p.owned() {
            let ri = radius_of(p.id[i]);
            let rho = self.case.materials[p.material[i] as usize].density;
            let m = rho * 4.0 / 3.0 * std::f64::consts::PI * ri.powi(3);
            let s = (p.radius[i] / p.minor[i]).sqrt();
            let before = p.radius[i];
            p.set_shape(i, ri * s, ri / s, m);
            // (NaN: not larger, but caught as a radius below)
            grown = grown.max(p.radius[i] - before);
        }
        // a clump's members (dumbbell discs) stay touching at its centre
        let c = &mut self.state.clumps;
        for k in 0..c.members.len() {
            c.half[k] = p.radius[c.members[k][0]];
        }
        c.refresh_mass(p);
        c.place(p);
        let nl = &mut self.state.nl;
        if self.par.size() == 1 && p.len() == p.owned() && p.radius[..p.owned()].iter().all(|r| r.is_finite() && *r > 0.0) {
            // no ghosts (one rank, no periodic images: a ghost would keep its
            // old radius until a build): the list stays, reaching further
            // until the next build (the drag beds' growth rebuilt it every
            // step). Under MPI each rank's growth would differ, and with it
            // the decision to rebuild, which every rank must make together.
            nl.radii_changed(p, &self.state.walls, grown);
        } else {
            self.rebuild_list();
        }
    }

    /// The current phase's name, or "end" after the last.
    pub fn phase_name(&self) -> &str {
        self.case.phases.get(self.state.phase).map(|p| p.name.as_str()).unwrap_or("end")
    }

    /// Total simulated time of all phases at most (s).
    pub fn planned_time(&self) -> f64 {
        self.case.phases.iter().map(|p| p.duration).sum()
    }

    /// Hash of every particle's id, position, velocity and spin, sorted by id
    /// (FNV-1a, 64 bit), over all ranks (a collective).
    pub fn state_hash(&self) -> String {
        // in order of id
        let (p, _) = self.par.gather_particles(&self.state.p, &self.state.gear);
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: u64| {
            for b in x.to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for i in 0..p.len() {
            eat(p.id[i]);
            for v in [p.pos[i], p.vel[i], p.omega[i]] {
                for k in 0..3 {
                    eat(v[k].to_bits());
                }
            }
        }
        format!("{h:016x}")
    }
}

/// A per-particle vector that `Simulation::set_particles` changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParticleField {
    Position,
    Velocity,
    Spin,
}

impl ParticleField {
    pub fn name(self) -> &'static str {
        match self {
            ParticleField::Position => "position",
            ParticleField::Velocity => "velocity",
            ParticleField::Spin => "spin",
        }
    }
}

/// The initial particles of a case, from its source. A lattice's memory is
/// checked before it is made, a list's or a CSV file's once read.
fn particle_inits(case: &Case, comm: &Comm) -> Result<Vec<ParticleInit>, TalusError> {
    let inits = match &case.particles.source {
        ParticleSource::Lattice(l) => {
            checks::memory(case, l.count, comm)?;
            return Ok(generate::lattice_cloud(l));
        }
        // every rank reads the file: one that cannot stops them all
        ParticleSource::Csv(f) => crate::parallel::agreed(comm, generate::read_csv(&case.resolve(f)))?,
        ParticleSource::List(list) => list_inits(&case.path.display().to_string(), list)?,
    };
    checks::memory(case, inits.len(), comm)?;
    Ok(inits)
}

/// Particles given one by one in `particles.list`, checked (radius, finite vectors, unique ids).
fn list_inits(path: &str, list: &[ParticleEntry]) -> Result<Vec<ParticleInit>, TalusError> {
    let mut seen = std::collections::HashSet::new();
    list.iter()
        .enumerate()
        .map(|(k, e)| {
            if !(e.radius > 0.0 && e.radius.is_finite()) {
                return Err(TalusError::Input(format!("{path}: particles.list[{k}].radius = {}: a radius must be positive", e.radius)));
            }
            for (key, v) in [("position", e.position), ("velocity", e.velocity), ("spin", e.spin)] {
                if v.iter().any(|x| !x.is_finite()) {
                    return Err(TalusError::Input(format!(
                        "{path}: particles.list[{k}].{key} = {v:?}: every component must be a finite number"
                    )));
                }
            }
            if !seen.insert(e.id) {
                return Err(TalusError::Input(format!("{path}: particles.list[{k}].id = {} appears twice", e.id)));
            }
            Ok(ParticleInit {
                id: e.id,
                pos: Vec3::from(e.position),
                vel: Vec3::from(e.velocity),
                omega: Vec3::from(e.spin),
                radius: e.radius,
            })
        })
        .collect()
}

/// The rank's threads: `[parallel] threads`, or the cores available to the
/// process shared among the ranks (at least one each).
///
/// The calling thread is one of the pool's threads: a parallel part of the
/// step then starts on it at once and the other threads join, instead of the
/// caller handing every part to the pool and sleeping until it comes back,
/// and there are no more threads than asked for to share the cores. Measured
/// on H1-small's whole run on 2 threads: 5.99 -> 6.6 million particle-steps/s.
/// A thread can belong to one such pool only, and for good (rayon keeps it),
/// so each thread keeps the first it makes (thread-local) and every later
/// simulation on that thread with the same thread count shares it: a
/// simulation made off the main thread (a test, the Python module), or the
/// second one on a thread, gains as `talus run` does (measured in
/// ARCHITECTURE.md, "Threads within a rank"). A simulation that asks such a thread for another count,
/// or one made on a thread of some other pool, gets a pool of its own threads.
fn thread_pool(case: &Case, par: &Parallel) -> Result<std::sync::Arc<rayon::ThreadPool>, TalusError> {
    use std::sync::Arc;
    thread_local! {
        static OWN: std::cell::RefCell<Option<(usize, Arc<rayon::ThreadPool>)>> = const { std::cell::RefCell::new(None) };
    }
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let n = case.parallel.threads.unwrap_or((cores / par.size()).max(1));
    if n > 1 {
        let own = OWN.with(|own| {
            let mut own = own.borrow_mut();
            if own.is_none() && rayon::current_thread_index().is_none() {
                if let Ok(pool) = rayon::ThreadPoolBuilder::new().num_threads(n).use_current_thread().build() {
                    *own = Some((n, Arc::new(pool)));
                }
            }
            own.as_ref().filter(|(m, _)| *m == n).map(|(_, pool)| pool.clone())
        });
        if let Some(pool) = own {
            return Ok(pool);
        }
    }
    rayon::ThreadPoolBuilder::new()
        .num_threads(n)
        .build()
        .map(Arc::new)
        .map_err(|e| TalusError::Run(format!("{}: cannot start {n} threads: {e}", case.path.display())))
}

/// The walls of a case, in the order the case gives them.
/// The walls of a case, in the order the case gives them, each moving as it
/// says (a wall that first turns in a later phase has that axis from the start,
/// turning at rate 0, for its axis torque).
fn build_walls(case: &Case) -> Result<Vec<Wall>, TalusError> {
    let mut walls = Vec::new();
    for w in &case.walls {
        let mut wall = Wall::new(&w.name, wall_shape(case, &w.shape)?, case.material_index(&w.material, "wall.material")?);
        wall.remove_at = w.remove_at;
        let later = case.phases.iter().flat_map(|p| &p.moves).find(|m| m.wall == w.name && m.rotation.is_some());
        let rotation = w.rotation.as_ref().or(later.and_then(|m| m.rotation.as_ref()));
        let rate = w.rotation.as_ref().map_or(0.0, |r| r.angular_velocity);
        set_motion(&mut wall, case, w.velocity, &w.oscillation, rotation.map(|r| (r, rate)), 0.0);
        if let Some(sv) = &w.servo {
            let direction = match (sv.direction, &wall.shape) {
                (Some(d), _) => Vec3::from(d).normalize(),
                (None, Shape::Plane(p)) => p.normal,
                (None, _) => unreachable!("checked: a servo wall that is not a plane gives its direction"),
            };
            wall.servo = Some(crate::walls::Servo { direction, target: sv.target(), gain: sv.gain, max_speed: sv.max_speed, travel: 0.0 });
        }
        walls.push(wall);
    }
    Ok(walls)
}

/// Prescribe a wall's motion, as given in the case, from time t on.
fn set_motion(
    wall: &mut Wall,
    case: &Case,
    velocity: [f64; 3],
    oscillation: &Option<crate::case::OscillationSection>,
    rotation: Option<(&crate::case::RotationSection, f64)>,
    t: f64,
) {
    let d = &case.simulation.domain;
    wall.set_motion(
        Vec3::from(velocity),
        oscillation.as_ref().map(|o| (Vec3::from(o.amplitude), o.frequency)),
        rotation.map(|(r, rate)| (Vec3::from(r.axis), Vec3::from(r.point), rate)),
        t,
        (Vec3::from(d.lo), Vec3::from(d.hi)),
    );
}

/// Apply phase `k`'s `[[phase.move]]` entries at time t.
fn apply_moves(walls: &mut [Wall], case: &Case, k: usize, t: f64) {
    let Some(ph) = case.phases.get(k) else { return };
    for m in &ph.moves {
        if let Some(w) = walls.iter_mut().find(|w| w.name == m.wall) {
            set_motion(w, case, m.velocity, &m.oscillation, m.rotation.as_ref().map(|r| (r, r.angular_velocity)), t);
        }
    }
}

/// A wall's geometry from the shape the case gives (an STL file is read here).
fn wall_shape(case: &Case, shape: &WallShape) -> Result<Shape, TalusError> {
    Ok(match shape {
        WallShape::Plane(pl) => Shape::Plane(Plane { point: Vec3::from(pl.point), normal: Vec3::from(pl.normal).normalize() }),
        WallShape::Disc(d) => Shape::Disc(Disc { center: Vec3::from(d.center), radius: d.radius }),
        WallShape::Segment(s) => Shape::Segments(Segments { segs: vec![[Vec3::from(s.from), Vec3::from(s.to)]] }),
        WallShape::Box(b) => {
            let c = |x: f64, y: f64| Vec3::new(x, y, 0.0);
            let (l, h) = (b.lo, b.hi);
            let k = [c(l[0], l[1]), c(h[0], l[1]), c(h[0], h[1]), c(l[0], h[1])];
            Shape::Segments(Segments { segs: (0..4).map(|i| [k[i], k[(i + 1) % 4]]).collect() })
        }
        WallShape::Stl(f) => Shape::Mesh(Mesh::from_stl(&case.resolve(f))?),
    })
}

/// Ellipses and clumps (dumbbells) run in 2D, with Verlet, on one rank.
fn serial_2d_verlet(case: &Case, comm: &Comm, key: &str, what: &str) -> Result<(), TalusError> {
    let path = case.path.display();
    if case.simulation.dimension != Dimension::Two || case.simulation.integrator != IntegratorKind::Verlet {
        return Err(TalusError::Input(format!("{path}: {key}: {what} need simulation.dimension = \"2\" and the verlet integrator")));
    }
    if comm.size() > 1 {
        return Err(TalusError::Input(format!("{path}: {key}: {what} run on one rank only (this run has {})", comm.size())));
    }
    Ok(())
}

/// Every particle of the case (all ranks hold all of them until the
/// decomposition keeps each rank's own), in id order, ellipses made.
fn build_particles(case: &Case, comm: &Comm) -> Result<Particles, TalusError> {
    let path = case.path.display();
    let pmat = case.material_index(&case.particles.material, "particles.material")?;
    let mat = &case.materials[pmat as usize];
    let inits = particle_inits(case, comm)?;
    if case.simulation.dimension == Dimension::Two {
        // 2D (as LIGGGHTS `dimension 2`): spheres moving in the x-y plane, spinning about z
        if let Some(i) = inits.iter().find(|i| i.pos.z != 0.0 || i.vel.z != 0.0 || i.omega.x != 0.0 || i.omega.y != 0.0) {
            return Err(TalusError::Input(format!(
                "{path}: particle id {}: position {:?}, velocity {:?}, spin {:?}: in 2D (simulation.dimension = \"2\") particles lie in z = 0, move in the x-y plane and spin about z",
                i.id, i.pos.as_slice(), i.vel.as_slice(), i.omega.as_slice()
            )));
        }
    }
    let mut p = Particles::default();
    for i in &inits {
        p.push_sphere(i, mat.density, pmat);
    }
    p.sort_by_id();
    make_ellipses(case, comm, &mut p)?;
    Ok(p)
}

/// Turn the particles `particles.ellipses` names into ellipses.
fn make_ellipses(case: &Case, comm: &Comm, p: &mut Particles) -> Result<(), TalusError> {
    if case.particles.ellipses.is_empty() {
        return Ok(());
    }
    let path = case.path.display();
    let key = "particles.ellipses";
    serial_2d_verlet(case, comm, key, "ellipses")?;
    let in_clump: std::collections::HashSet<u64> = case.particles.clumps.iter().flatten().copied().collect();
    for (k, e) in case.particles.ellipses.iter().enumerate() {
        let i = p
            .id
            .binary_search(&e.id)
            .map_err(|_| TalusError::Input(format!("{path}: {key}[{k}].id = {}: no particle with this id", e.id)))?;
        if p.ellipse[i] {
            return Err(TalusError::Input(format!("{path}: {key}[{k}].id = {}: listed twice", e.id)));
        }
        if in_clump.contains(&e.id) {
            return Err(TalusError::Input(format!("{path}: {key}[{k}].id = {}: a clump member cannot be an ellipse", e.id)));
        }
        if !(e.aspect_ratio >= 1.0 && e.aspect_ratio <= 10.0) {
            return Err(TalusError::Input(format!(
                "{path}: {key}[{k}].aspect_ratio = {}: must be in [1, 10] (a/b, a the major semi-axis)",
                e.aspect_ratio
            )));
        }
        if !e.angle.is_finite() {
            return Err(TalusError::Input(format!("{path}: {key}[{k}].angle = {}: must be a finite number", e.angle)));
        }
        p.make_ellipse(i, e.aspect_ratio, e.angle);
    }
    Ok(())
}

/// The time step (s), the Rayleigh time of the smallest particle (s; an
/// ellipse counts with its minor semi-axis) and that radius (m); a step above
/// 30% of the Rayleigh time, or one that resolves the stiffest explicit
/// contact in fewer than 20 steps, is refused unless forced.
fn time_step(case: &Case, p: &Particles) -> Result<(f64, f64, f64), TalusError> {
    let mat = &case.materials[case.material_index(&case.particles.material, "particles.material")? as usize];
    let mut rmin = p.minor.iter().cloned().fold(f64::INFINITY, f64::min);
    let mut tr = if rmin.is_finite() { rayleigh_time(rmin, mat.density, mat.shear_modulus(), mat.poisson_ratio) } else { f64::INFINITY };
    // the smallest particle a phase will insert counts too
    for ins in case.phases.iter().flat_map(|ph| &ph.inserts) {
        let m = &case.materials[case.material_index(&ins.material, "insert.material")? as usize];
        let r = crate::insert::min_radius(&ins.radius);
        rmin = rmin.min(r);
        tr = tr.min(rayleigh_time(r, m.density, m.shear_modulus(), m.poisson_ratio));
    }
    let s = &case.simulation;
    let dt = match s.timestep {
        TimeStep::Seconds(dt) => dt,
        TimeStep::RayleighFraction(f) => f * tr,
    };
    if dt > 0.3 * tr && !s.force_timestep {
        return Err(TalusError::Input(format!(
            "{}: simulation.timestep = {dt:.4e} s is {:.0}% of the Rayleigh time {tr:.4e} s of the smallest particle (radius {rmin:.4e} m); the limit is 30% (set simulation.force_timestep = true to run anyway)",
            case.path.display(),
            100.0 * dt / tr
        )));
    }
    checks::contact_period(case, p, dt)?;
    Ok((dt, tr, rmin))
}

/// No two particles may start overlapping by more than `particles.overlap_tolerance`.
fn check_initial_overlaps(case: &Case, p: &Particles, nl: &NeighborList) -> Result<(), TalusError> {
    let tol = case.particles.overlap_tolerance;
    for &(a, b) in &nl.pairs {
        let (a, b) = (a as usize, b as usize);
        let ov = if p.ellipse[a] || p.ellipse[b] {
            crate::contact::ellipse::contact(&p.ellipse_of(a), &p.ellipse_of(b)).map_or(0.0, |c| c.overlap)
        } else {
            p.radius[a] + p.radius[b] - (p.pos[a] - p.pos[b]).norm()
        };
        if ov > tol * p.radius[a].min(p.radius[b]) {
            return Err(TalusError::Input(format!(
                "{}: particles {} and {} overlap by {ov:.4e} m initially, more than particles.overlap_tolerance = {tol} of the smaller radius",
                case.path.display(),
                p.id[a],
                p.id[b]
            )));
        }
    }
    Ok(())
}

/// In a periodic domain, the start's overlaps across the periodic faces too:
/// the particles with their images near the domain (shifted copies, as ghosts
/// of the check's own list), through the same test.
fn check_periodic_overlaps(case: &Case, p: &Particles, domain: &Domain, skin: f64) -> Result<(), TalusError> {
    let period = Vec3::from(case.simulation.domain.period());
    if period == Vec3::zeros() {
        return Ok(());
    }
    let reach = 2.0 * p.radius.iter().cloned().fold(0.0, f64::max) + skin;
    let mut q = p.clone();
    let mut images = 0;
    for g in crate::parallel::image_shifts(&period).into_iter().skip(1) {
        let s = crate::particles::image_shift(&g, &period);
        for i in 0..p.len() {
            let x = p.pos[i] + s;
            if (0..3).all(|k| x[k] > domain.lo[k] - reach && x[k] < domain.hi[k] + reach) {
                let mut r = p.record(i);
                r.pos = x;
                q.push_record(&r);
                images += 1;
            }
        }
    }
    q.ghosts = images;
    let mut nl = NeighborList::new(skin);
    nl.build(&q, &[]);
    check_initial_overlaps(case, &q, &nl)
}

/// The rigid clumps (dumbbells) `particles.clumps` names.
fn build_clumps(case: &Case, comm: &Comm, p: &mut Particles) -> Result<Clumps, TalusError> {
    if case.particles.clumps.is_empty() {
        return Ok(Clumps::default());
    }
    let path = case.path.display();
    let key = "particles.clumps";
    serial_2d_verlet(case, comm, key, "clumps (dumbbells)")?;
    let mut seen = std::collections::HashSet::new();
    let mut pairs = Vec::new();
    for (k, &[a, b]) in case.particles.clumps.iter().enumerate() {
        let mut idx = [0usize; 2];
        for (j, id) in [a, b].into_iter().enumerate() {
            idx[j] = p
                .id
                .binary_search(&id)
                .map_err(|_| TalusError::Input(format!("{path}: {key}[{k}] = [{a}, {b}]: no particle with id {id}")))?;
            if !seen.insert(id) {
                return Err(TalusError::Input(format!("{path}: {key}[{k}] = [{a}, {b}]: particle {id} is in two clumps")));
            }
        }
        pairs.push(idx);
    }
    Ok(Clumps::new(p, &pairs))
}

/// The parallel runtime: the grid (the case's, or the one with the least cut
/// area), planes giving every box the same particle count, balancing settings.
fn build_parallel(case: &Case, comm: Rc<Comm>, p: &Particles, domain: &Domain, skin: f64) -> Result<Parallel, TalusError> {
    let nranks = comm.size();
    let grid = case.parallel.grid.unwrap_or_else(|| choose_grid(nranks, domain.hi - domain.lo));
    if grid.iter().product::<usize>() != nranks {
        return Err(TalusError::Input(format!(
            "{}: parallel.grid = {grid:?}: {} boxes for {nranks} MPI ranks; the product must equal the number of ranks",
            case.path.display(),
            grid.iter().product::<usize>()
        )));
    }
    let mut dec = Decomposition::new(grid, domain.lo, domain.hi);
    dec.fit(&Comm::Serial, &p.pos, &vec![1.0; p.len()]);
    // the largest particle of the run, inserted ones included: it sets how far ghosts reach
    let rmax = case
        .phases
        .iter()
        .flat_map(|ph| &ph.inserts)
        .map(|ins| crate::insert::max_radius(&ins.radius))
        .fold(p.radius.iter().cloned().fold(0.0, f64::max), f64::max);
    let pc = &case.parallel;
    let balance = BalanceSettings { mode: pc.balance, tolerance: pc.imbalance_percent / 100.0, interval: pc.balance_interval };
    let range = 2.0 * rmax + skin;
    let mut par = Parallel::new(comm, dec, range, balance);
    par.order = pc.order;
    par.period = Vec3::from(case.simulation.domain.period());
    // a particle must meet at most one image of another: each period longer
    // than twice the reach of the neighbour search
    for (k, a) in ["x", "y", "z"].iter().enumerate() {
        let l = par.period[k];
        if l > 0.0 && l <= 2.0 * range {
            return Err(TalusError::Input(format!(
                "{}: simulation.domain.periodic: the period along {a} is {l:.4e} m, not longer than twice the neighbour reach (2 x (largest diameter {:.4e} m + skin {skin:.4e} m) = {:.4e} m); make the domain longer along {a}",
                case.path.display(),
                2.0 * rmax,
                2.0 * range
            )));
        }
    }
    Ok(par)
}
