//! A simulation: settings derived once from the case, and the state that a
//! checkpoint saves. The time step, in order:
//!
//! 1. integrator first half (Verlet: half kick + drift; Gear: predict);
//! 2. walls move by their prescribed velocities;
//! 3. neighbour lists are checked (domain, NaN) and rebuilt if any particle moved
//!    more than half the skin;
//! 4. forces: gravity, pairs in (id_a, id_b) order, walls in order;
//! 5. integrator second half (Verlet: half kick; Gear: correct);
//! 6. time advances; analysis and probes record; phase end conditions are checked.

use crate::analysis::Analysis;
use crate::case::{Case, ModelName, WallContactPoint};
use crate::contact::hertz::{Hertz, HertzDamping};
use crate::contact::hooke::Hooke;
use crate::contact::{Convention, EndOfContact, FrictionCap, ShearKinematics, TangentialHistory, TangentialOptions};
use crate::dim::{Dimension, Vec3};
use crate::error::TalusError;
use crate::forces::{compute_forces, ContactModel, SweepSettings};
use crate::generate;
use crate::integrate::{self, GearState, IntegratorKind};
use crate::material::{Mixing, PairTable};
use crate::neighbor::{Domain, NeighborList};
use crate::particles::Particles;
use crate::walls::{Mesh, Plane, Shape, Wall};
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
}

pub struct Simulation {
    pub case: Case,
    pub set: Settings,
    pub table: PairTable,
    pub state: State,
}

/// Rayleigh time of a sphere: pi R sqrt(rho / G) / (0.1631 nu + 0.8766).
pub fn rayleigh_time(radius: f64, density: f64, shear_modulus: f64, nu: f64) -> f64 {
    std::f64::consts::PI * radius * (density / shear_modulus).sqrt() / (0.1631 * nu + 0.8766)
}

impl Simulation {
    /// Build a simulation from a validated case: particles, walls, lists, checks.
    pub fn new(case: Case) -> Result<Simulation, TalusError> {
        let path = case.path.display().to_string();
        let conv = case.contact.convention;
        let mixing = match conv {
            Convention::Liggghts | Convention::Talus => Mixing::Liggghts,
            Convention::Yade => Mixing::Yade,
        };
        let table = PairTable::new(&case.materials, mixing);
        let pmat = case.material_index(&case.particles.material, "particles.material")?;
        let mat = &case.materials[pmat as usize];

        // particles
        let inits = if let Some(l) = &case.particles.lattice {
            generate::lattice_cloud(l)
        } else if let Some(f) = &case.particles.csv {
            generate::read_csv(&case.resolve(f))?
        } else {
            let list = case.particles.list.as_ref().expect("validated");
            let mut seen = std::collections::HashSet::new();
            list.iter()
                .enumerate()
                .map(|(k, e)| {
                    if !(e.radius > 0.0 && e.radius.is_finite()) {
                        return Err(TalusError::Input(format!(
                            "{path}: particles.list[{k}].radius = {}: a radius must be positive",
                            e.radius
                        )));
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
                    Ok(crate::particles::ParticleInit {
                        id: e.id,
                        pos: Vec3::from(e.position),
                        vel: Vec3::from(e.velocity),
                        omega: Vec3::from(e.spin),
                        radius: e.radius,
                    })
                })
                .collect::<Result<Vec<_>, _>>()?
        };
        let mut p = Particles::default();
        for i in &inits {
            p.push_sphere(i, mat.density, pmat);
        }
        p.sort_by_id();

        // time step against the Rayleigh time of the smallest particle
        let rmin = p.radius.iter().cloned().fold(f64::INFINITY, f64::min);
        let tr = rayleigh_time(rmin, mat.density, mat.shear_modulus(), mat.poisson_ratio);
        let s = &case.simulation;
        let dt = match (s.timestep, s.timestep_rayleigh_fraction) {
            (Some(dt), _) => dt,
            (_, Some(f)) => f * tr,
            _ => unreachable!("validated"),
        };
        if dt > 0.3 * tr && !s.force_timestep {
            return Err(TalusError::Input(format!(
                "{path}: simulation.timestep = {dt:.4e} s is {:.0}% of the Rayleigh time {tr:.4e} s of the smallest particle (radius {rmin:.4e} m); the limit is 30% (set simulation.force_timestep = true to run anyway)",
                100.0 * dt / tr
            )));
        }

        // walls
        let mut walls = Vec::new();
        for w in &case.walls {
            let shape = if let Some(pl) = &w.plane {
                Shape::Plane(Plane { point: Vec3::from(pl.point), normal: Vec3::from(pl.normal).normalize() })
            } else {
                Shape::Mesh(Mesh::from_stl(&case.resolve(w.stl.as_ref().expect("validated")))?)
            };
            walls.push(Wall {
                name: w.name.clone(),
                shape,
                material: case.material_index(&w.material, "wall.material")?,
                velocity: Vec3::from(w.velocity),
                active: true,
                remove_at: w.remove_at,
                force: Vec3::zeros(),
                torque: Vec3::zeros(),
            });
        }

        let c = &case.contact;
        let model = match c.model {
            ModelName::Hooke => ContactModel::Hooke(match (c.stiffness, c.characteristic_velocity) {
                (Some(h), _) => Hooke::Explicit(h),
                (_, Some(v)) => Hooke::Derived { characteristic_velocity: v },
                _ => unreachable!("validated"),
            }),
            ModelName::Hertz => ContactModel::Hertz(Hertz {
                damping: c.damping.unwrap_or(match conv {
                    Convention::Liggghts | Convention::Talus => HertzDamping::Liggghts,
                    Convention::Yade => HertzDamping::Yade,
                }),
            }),
        };
        let end = c.end_of_contact.unwrap_or(match conv {
            Convention::Liggghts | Convention::Talus => EndOfContact::Tensile,
            Convention::Yade => EndOfContact::Clip,
        });
        let history = c.tangential.unwrap_or(match conv {
            Convention::Liggghts | Convention::Talus => TangentialHistory::Total,
            Convention::Yade => TangentialHistory::Incremental,
        });
        // YADE: Mindlin increments shear with full radii; ViscEl with the contact point
        let kinematics = c.shear_kinematics.unwrap_or(match (conv, c.model) {
            (Convention::Yade, ModelName::Hertz) => ShearKinematics::FullRadii,
            _ => ShearKinematics::ContactPoint,
        });
        let wall_contact = c.wall_contact_point.unwrap_or(match conv {
            Convention::Yade => WallContactPoint::Surface,
            _ => WallContactPoint::MidOverlap,
        });
        let cap = c.friction_cap.unwrap_or(match conv {
            Convention::Talus => FrictionCap::Elastic,
            Convention::Liggghts | Convention::Yade => FrictionCap::Total,
        });
        let domain = Domain { lo: Vec3::from(s.domain.lo), hi: Vec3::from(s.domain.hi) };
        let set = Settings {
            dt,
            dim: s.dimension,
            sweep: SweepSettings {
                model,
                end,
                tang: TangentialOptions { history, cap, kinematics },
                gravity: Vec3::from(s.gravity),
                dt,
                wall_arm_overlap: match wall_contact {
                    WallContactPoint::MidOverlap => 0.5,
                    WallContactPoint::Surface => 1.0,
                },
            },
            integrator: s.integrator,
            domain,
            rayleigh_time: tr,
        };
        let skin = s.skin.unwrap_or(0.2 * rmin);
        let mut nl = NeighborList::new(skin);
        nl.build(&p, &walls, &domain).map_err(|e| TalusError::Input(format!("{path}: initial state: {e}")))?;
        // initial overlaps
        let tol = case.particles.overlap_tolerance;
        for &(a, b) in &nl.pairs {
            let (a, b) = (a as usize, b as usize);
            let ov = p.radius[a] + p.radius[b] - (p.pos[a] - p.pos[b]).norm();
            if ov > tol * p.radius[a].min(p.radius[b]) {
                return Err(TalusError::Input(format!(
                    "{path}: particles {} and {} overlap by {ov:.4e} m initially, more than particles.overlap_tolerance = {tol} of the smaller radius",
                    p.id[a], p.id[b]
                )));
            }
        }
        let pe0 = p.potential_energy(set.sweep.gravity);
        let analysis = Analysis::new(&case, &p, &walls)?;
        let state = State {
            p,
            walls,
            nl,
            gear: GearState::default(),
            time: 0.0,
            step: 0,
            phase: 0,
            phase_start: 0.0,
            settle_end: None,
            pe0,
            forces_ready: false,
            contacts: 0,
            analysis,
        };
        Ok(Simulation { case, set, table, state })
    }

    fn refresh_lists(&mut self) -> Result<(), TalusError> {
        let st = &mut self.state;
        if st.nl.needs_rebuild(&st.p, &self.set.domain)? {
            st.nl.build(&st.p, &st.walls, &self.set.domain)?;
        }
        Ok(())
    }

    fn forces(&mut self) {
        let st = &mut self.state;
        st.contacts = compute_forces(&self.set.sweep, &mut st.p, &mut st.walls, &mut st.nl, &self.table);
    }

    /// Forces at the current state, once before the first step.
    pub fn prepare(&mut self) -> Result<(), TalusError> {
        if !self.state.forces_ready {
            self.refresh_lists()?;
            self.forces();
            if self.set.integrator == IntegratorKind::Gear {
                self.state.gear.init(&self.state.p, self.set.dt, self.set.dim);
            }
            self.state.forces_ready = true;
            self.record();
        }
        Ok(())
    }

    fn record(&mut self) {
        let mut a = std::mem::replace(&mut self.state.analysis, Analysis::None);
        a.record(&self.state);
        self.state.analysis = a;
    }

    /// Advance one time step.
    pub fn step(&mut self) -> Result<(), TalusError> {
        self.prepare()?;
        let dt = self.set.dt;
        let dim = self.set.dim;
        match self.set.integrator {
            IntegratorKind::Verlet => integrate::verlet_first(&mut self.state.p, dt, dim),
            IntegratorKind::Gear => self.state.gear.predict(&mut self.state.p, dt),
        }
        let mut moved: f64 = 0.0;
        for w in &mut self.state.walls {
            w.advance(dt);
            if w.active {
                moved = moved.max(w.velocity.norm() * dt);
            }
        }
        self.state.nl.wall_moved += moved;
        self.refresh_lists()?;
        self.forces();
        match self.set.integrator {
            IntegratorKind::Verlet => integrate::verlet_second(&mut self.state.p, dt, dim),
            IntegratorKind::Gear => self.state.gear.correct(&mut self.state.p, dt, dim),
        }
        self.state.step += 1;
        self.state.time = self.state.step as f64 * dt;
        self.record();
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
        let st = &mut self.state;
        let Some(ph) = self.case.phases.get(st.phase) else { return Ok(false) };
        let elapsed = st.time - st.phase_start;
        let dt = self.set.dt;
        let mut done = elapsed >= ph.duration - 0.5 * dt;
        if let Some(frac) = ph.kinetic_energy_fraction {
            if st.settle_end.is_none() && st.step % 20 == 0 {
                let drop = st.pe0 - st.p.potential_energy(self.set.sweep.gravity);
                if drop > 0.0 && st.p.kinetic_energy() < frac * drop {
                    st.settle_end = Some(st.time + ph.settle_extra);
                }
            }
            if let Some(t) = st.settle_end {
                done |= st.time >= t - 0.5 * dt;
            }
        }
        if done {
            st.analysis.phase_end(&ph.name, st.time);
            for name in &ph.remove_walls_at_end {
                if let Some(w) = st.walls.iter_mut().find(|w| &w.name == name) {
                    w.active = false;
                }
            }
            st.phase += 1;
            st.phase_start = st.time;
            st.settle_end = None;
        }
        Ok(self.state.phase < self.case.phases.len())
    }

    /// Total simulated time of all phases at most (s).
    pub fn planned_time(&self) -> f64 {
        self.case.phases.iter().map(|p| p.duration).sum()
    }

    /// Hash of every particle's id, position, velocity and spin, sorted by id (FNV-1a, 64 bit).
    pub fn state_hash(&self) -> String {
        let p = &self.state.p;
        let mut order: Vec<usize> = (0..p.len()).collect();
        order.sort_by_key(|&i| p.id[i]);
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |x: u64| {
            for b in x.to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0000_0100_0000_01b3);
            }
        };
        for i in order {
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
