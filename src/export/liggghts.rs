//! A case as a LIGGGHTS 3.8 deck (`in.talus`), with its particle data file
//! and meshes, writing `probes.csv` with talus's columns.
//!
//! The deck is in LIGGGHTS's conventions (talus with `contact.convention =
//! "liggghts"` runs the same equations): Hertz (`model hertz`) or Hooke
//! (`hooke` derived at a characteristic velocity, or `hooke/stiffness` with
//! absolute coefficients), `tangential history`, pair restitution and friction
//! the mean of the two materials'. How it is laid out:
//!
//! - particles: `particles.data` (atom type = material index + 1, diameter,
//!   density; velocities and spins), the very particles talus starts from;
//! - walls: an STL mesh, or a plane that slides within itself or is not
//!   normal to x, y or z (written as a mesh across the domain,
//!   sliding by its `surface_vel`), is a `mesh/surface/stress` in one
//!   `wall/gran` fix; a still plane normal to an axis is a `primitive` wall in
//!   a fix of its own (`store_force` gives its load), so it can be removed
//!   alone. A moving mesh (an STL mesh, or a plane moving along its normal) is
//!   moved by `fix move/mesh`: `linear`, `wiggle` (which moves the mesh by dt
//!   times its velocity at the step's end: O(w dt) from talus's exact
//!   displacement), then `rotate` (created after
//!   the translations, the rotation turns about the axis they carry); a phase
//!   that changes the motion unfixes them (newest first) and creates the new
//!   ones at its start. A turning mesh's `reference_point` is on its axis (it
//!   moves and turns with the mesh; f_NAME[7..9] is where it is now), so
//!   f_NAME[4..6] . axis is the axis torque, and the torque about the origin is
//!   f[4..6] + f[7..9] x f[1..3]. (This LIGGGHTS stops in `fix move/mesh` with
//!   "Illegal situation in MultiNodeMesh::registerMove" only when the mesh has
//!   no triangles, e.g. a binary STL whose header starts with "solid".) A
//!   ball wall is moved by `fix move` (linear or wiggle);
//! - probes: one `fix print` for the whole run, every round(interval / dt)
//!   steps, from step 0; the phase name is a string variable, a removed wall's
//!   columns variables set to 0;
//! - phases: runs of their whole length; one that ends on kinetic energy runs
//!   in chunks up to each multiple of 20 steps (talus's test steps) and tests
//!   KE < fraction x (PE0 - PE) between chunks, then runs its settle time.
//!   Chunks are `run N pre no post no` (no set-up between them: LIGGGHTS's
//!   set-up recomputes forces without updating the shear history). A wall
//!   removal needs a set-up once (the next run is `pre yes`); removing a mesh
//!   wall re-creates the mesh fix, so the contacts with the other meshes start
//!   again without history.

use super::{phase_steps, refuse, removal_step, Exported};
use crate::case::{Case, ModelName, WallShape};
use crate::contact::conventions::resolve;
use crate::contact::hertz::HertzDamping;
use crate::contact::{Convention, EndOfContact, FrictionCap, ShearKinematics, TangentialHistory};
use crate::dim::{Dimension, Vec3};
use crate::error::TalusError;
use crate::integrate::IntegratorKind;
use crate::material::{mix, Mixing};
use crate::sim::Simulation;
use crate::walls::mesh::Mesh;
use crate::walls::Shape;
use std::fmt::Write as _;
use std::path::Path;

/// Why a plane that turns, or moves within itself in more than one way, is refused.
const PLANE_MOTION: &str = "a moving plane is a finite mesh across the domain in the LIGGGHTS deck: it may move along its normal (and, if that is its only motion, slide within itself as the mesh's `surface_vel`), but turning or oscillating within itself it would leave the domain; give the wall as an STL mesh";

/// How a wall is written.
#[derive(Clone, Debug)]
enum Kind {
    /// `mesh/surface/stress` in the shared `wall/gran` fix.
    Mesh,
    /// A `primitive` plane in a fix of its own: axis (0 x, 1 y, 2 z) and offset.
    Primitive { axis: usize, at: f64 },
    /// A ball (2D: a disc, the drag paper's cylinder): one atom of the wall's
    /// type and radius, too heavy to feel its contacts (density 1e15), moved by
    /// `fix move linear` and left out of the integration; its id.
    Ball { atom: u64 },
}

struct W {
    name: String,
    kind: Kind,
    atom_type: usize,
    /// A plane's velocity within itself: the mesh's `surface_vel` (a conveyor belt).
    surface_vel: Vec3,
    /// Its motions by `fix move/mesh` (a mesh) or `fix move` (a ball), each from
    /// the start of a phase: (phase, velocity, oscillation (amplitude, Hz),
    /// rotation (unit axis, point, rad/s)).
    motions: Vec<Motion>,
    /// A mesh that turns in some phase: its axis (point, unit direction), the
    /// mesh's `reference_point` (which moves and turns with the mesh).
    axis: Option<(Vec3, Vec3)>,
}

#[derive(Clone, Debug)]
struct Motion {
    phase: usize,
    velocity: Vec3,
    oscillation: Option<(Vec3, f64)>,
    rotation: Option<(Vec3, Vec3, f64)>,
}

impl Motion {
    fn from(m: &super::MotionAt) -> Motion {
        Motion {
            phase: m.phase,
            velocity: Vec3::from(m.velocity),
            oscillation: m.oscillation.map(|o| (Vec3::from(o.amplitude), o.frequency)),
            rotation: m.rotation.map(|r| (Vec3::from(r.axis).normalize(), Vec3::from(r.point), r.angular_velocity)),
        }
    }
}

/// The `fix move/mesh` commands of a mesh's motion, in the order LIGGGHTS
/// needs (translations first: a rotation created after them turns about the
/// axis they carry); their fix ids are pushed to `ids`.
fn mesh_moves(w: &mut String, name: &str, m: &Motion, ids: &mut Vec<String>) {
    let tag = format!("{name}_mv{}", m.phase);
    if m.velocity != Vec3::zeros() {
        let v = m.velocity;
        let _ = writeln!(w, "fix {tag}l all move/mesh mesh {name} linear {} {} {}", g(v.x), g(v.y), g(v.z));
        ids.push(format!("{tag}l"));
    }
    if let Some((a, f)) = m.oscillation {
        let _ = writeln!(w, "fix {tag}w all move/mesh mesh {name} wiggle amplitude {} {} {} period {}", g(a.x), g(a.y), g(a.z), g(1.0 / f));
        ids.push(format!("{tag}w"));
    }
    if let Some((axis, p, rate)) = m.rotation {
        if rate != 0.0 {
            // period 2 pi / |rate|, about the axis turned to the rate's sense
            let a = axis * rate.signum();
            let _ = writeln!(
                w,
                "fix {tag}r all move/mesh mesh {name} rotate origin {} {} {} axis {} {} {} period {}",
                g(p.x),
                g(p.y),
                g(p.z),
                g(a.x),
                g(a.y),
                g(a.z),
                g(2.0 * std::f64::consts::PI / rate.abs())
            );
            ids.push(format!("{tag}r"));
        }
    }
}

fn g(x: f64) -> String {
    // 17 significant digits: every f64 reaches LIGGGHTS as it is
    format!("{x:.16e}")
}

fn io(path: &Path, e: std::io::Error) -> TalusError {
    TalusError::io(format!("writing {}", path.display()), e)
}

/// The LIGGGHTS contact model a case's law is written as.
#[derive(Clone, Copy, Debug)]
enum Law {
    /// `model hertz`.
    Hertz,
    /// `model hooke/stiffness` with these absolute coefficients.
    HookeStiffness(crate::contact::hooke::HookeExplicit),
    /// `model hooke` at this characteristic velocity (m/s).
    HookeDerived(f64),
}

/// The case's normal law as LIGGGHTS writes it, or refused by name (every
/// model decided here: a new one does not compile until it is).
fn law(case: &Case) -> Result<Law, TalusError> {
    let c = &case.contact;
    // per pair of atom types LIGGGHTS holds only the cohesion's energy density
    // (cohesionEnergyDensity); every other key of a pair is refused by name
    for (k, pr) in c.pairs.iter().enumerate() {
        let crate::case::ContactPair { materials, model, damping, characteristic_velocity, stiffness, surface_energy, cohesion: _ } = pr;
        let set = [
            ("model", model.is_some()),
            ("damping", damping.is_some()),
            ("characteristic_velocity", characteristic_velocity.is_some()),
            ("stiffness", stiffness.is_some()),
            ("surface_energy", surface_energy.is_some()),
        ];
        if let Some((key, _)) = set.iter().find(|x| x.1) {
            return Err(refuse(case, &format!("contact.pair[{k}].{key} (materials {materials:?})"), "LIGGGHTS 3.8's pair style takes one contact model for every pair of atom types, and per pair of types only the cohesion's energy density; compare laws per pair of materials against LAMMPS (--engines talus,lammps)"));
        }
    }
    cohesion_model(case)?;
    match c.model {
        ModelName::Hertz => Ok(Law::Hertz),
        ModelName::Hooke => match (c.stiffness, c.characteristic_velocity) {
            (Some(k), _) => Ok(Law::HookeStiffness(k)),
            (None, v) => Ok(Law::HookeDerived(v.unwrap_or(1.0))),
        },
        m @ (ModelName::Dmt | ModelName::Jkr) => Err(refuse(
            case,
            &format!("contact.model = \"{}\"", m.name()),
            "LIGGGHTS 3.8 has no DMT or JKR normal model; its cohesion is `cohesion sjkr` / `sjkr2` (contact.cohesion with model hertz or hooke); compare dmt and jkr against LAMMPS (--engines talus,lammps)",
        )),
    }
}

/// The cohesion model of the pair style and of every wall fix. LIGGGHTS writes
/// one, so every pair of materials' cohesion (its `[[contact.pair]]`'s, else the
/// section's) must name the same; their energy densities go per pair of atom
/// types (zero where a pair has none).
fn cohesion_model(case: &Case) -> Result<Option<crate::contact::cohesion::CohesionModel>, TalusError> {
    let mut model = case.contact.cohesion.map(|c| c.model);
    for (k, pr) in case.contact.pairs.iter().enumerate() {
        if let Some(c) = pr.cohesion {
            match model {
                Some(m) if m != c.model => {
                    return Err(refuse(
                        case,
                        &format!("contact.pair[{k}].cohesion.model = \"{}\"", c.model.name()),
                        &format!("LIGGGHTS 3.8 takes one cohesion model for every pair of atom types, and another pair or the section names \"{}\"", m.name()),
                    ))
                }
                _ => model = Some(c.model),
            }
        }
    }
    Ok(model)
}

/// Refuse what LIGGGHTS 3.8 cannot run, naming the key; the law as it is written.
fn check(case: &Case) -> Result<Law, TalusError> {
    let s = &case.simulation;
    if s.integrator == IntegratorKind::Gear {
        return Err(refuse(case, "simulation.integrator = \"gear\"", "LIGGGHTS 3.8 integrates spheres with velocity Verlet (nve/sphere) only"));
    }
    if !case.particles.ellipses.is_empty() {
        return Err(refuse(case, "particles.ellipses", "LIGGGHTS 3.8 has no ellipse particles"));
    }
    if !case.particles.clumps.is_empty() {
        return Err(refuse(case, "particles.clumps", "the LIGGGHTS exporter writes no clumps (multisphere is not in LIGGGHTS-PUBLIC 3.8)"));
    }
    // a mesh wall removed while another stays: the deck would define the mesh
    // contacts' wall/gran/local compute again after the first run, which LIGGGHTS
    // 3.8 refuses ("Need to define this compute before first run")
    let meshes: Vec<&str> = case.walls.iter().filter(|w| matches!(w.shape, WallShape::Stl(_))).map(|w| w.name.as_str()).collect();
    if meshes.len() > 1 {
        let removed_at = case.walls.iter().filter(|w| w.remove_at.is_some()).map(|w| (w.name.as_str(), "wall.remove_at".to_string()));
        let removed_end = case.phases.iter().enumerate().flat_map(|(k, p)| p.remove_walls_at_end.iter().map(move |n| (n.as_str(), format!("phase[{k}].remove_walls_at_end"))));
        if let Some((name, key)) = removed_at.chain(removed_end).find(|(n, _)| meshes.contains(n)) {
            return Err(refuse(
                case,
                &key,
                &format!("removes the mesh wall \"{name}\" while other mesh walls stay: LIGGGHTS 3.8 cannot define the mesh contacts' wall/gran/local compute again after the first run"),
            ));
        }
    }
    let law = law(case)?;
    let c = &case.contact;
    // each option LIGGGHTS cannot hold, by name (every value decided: a new
    // one does not compile until it is)
    match c.damping {
        None | Some(HertzDamping::Liggghts) => {}
        Some(d @ (HertzDamping::Yade | HertzDamping::Tsuji)) => {
            return Err(refuse(
                case,
                &format!("contact.damping = \"{}\"", d.name()),
                "LIGGGHTS maps restitution to damping its own way (gamma_n = 2 sqrt(5/6) beta sqrt(S_n m*))",
            ))
        }
    }
    match c.tangential {
        None | Some(TangentialHistory::Total) => {}
        Some(t @ (TangentialHistory::Incremental | TangentialHistory::Rescaled)) => {
            return Err(refuse(
                case,
                &format!("contact.tangential = \"{}\"", t.name()),
                "LIGGGHTS `tangential history` keeps the total shear displacement, projected without rescaling",
            ))
        }
    }
    match c.shear_kinematics {
        None | Some(ShearKinematics::ContactPoint) => {}
        Some(k @ (ShearKinematics::FullRadii | ShearKinematics::Radii)) => {
            return Err(refuse(case, &format!("contact.shear_kinematics = \"{}\"", k.name()), "LIGGGHTS drives the shear spring by the contact point's velocity"));
        }
    }
    match c.friction_cap {
        None | Some(FrictionCap::Total) => {}
        Some(f @ (FrictionCap::Elastic | FrictionCap::Pulloff)) => {
            return Err(refuse(case, &format!("contact.friction_cap = \"{}\"", f.name()), "LIGGGHTS caps friction with the total normal force"))
        }
    }
    match c.wall_contact_point {
        None | Some(crate::case::WallContactPoint::MidOverlap) => {}
        Some(p @ (crate::case::WallContactPoint::Surface | crate::case::WallContactPoint::Radius)) => {
            return Err(refuse(case, &format!("contact.wall_contact_point = \"{}\"", p.name()), "LIGGGHTS acts at the middle of a wall overlap"));
        }
    }
    if let Some(w) = case.walls.iter().find(|w| w.servo.is_some()) {
        return Err(refuse(
            case,
            &format!("wall.{}.servo", w.name),
            "LIGGGHTS's servo wall (fix mesh/surface/stress/servo) runs its own controller (a PID on the error over the set point, scaled by vel_max, with hard-coded gains in its auto mode), not talus's; the deck would not hold the same load the same way",
        ));
    }
    for (i, w) in case.walls.iter().enumerate() {
        match &w.shape {
            WallShape::Segment(_) | WallShape::Box(_) => {
                return Err(refuse(
                    case,
                    &format!("wall[{i}].{} ({})", w.shape.key(), w.name),
                    "LIGGGHTS 3.8 has no 2D segment wall; give the walls as planes",
                ));
            }
            _ => {}
        }
    }
    Ok(law)
}

/// A plane as a mesh inside the domain (LIGGGHTS stops on a mesh node outside
/// the simulation box, and loses a mesh of two domain-wide triangles: "Mesh
/// error - mesh empty"), an 8 x 8 grid of squares, two triangles each: for a
/// plane normal to an axis, the domain's cross-section at the plane, shrunk
/// by 1e-6 of its size; for any other plane, the square of side the domain's
/// smallest extent centred where the plane meets the domain's centre line
/// along its normal.
fn plane_mesh(point: Vec3, n: Vec3, lo: Vec3, hi: Vec3) -> Mesh {
    let axis = (0..3).find(|&k| n[k].abs() == 1.0);
    let (origin, du, dv) = if let Some(k) = axis {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let e = 1e-6 * (hi - lo).norm();
        let mut o = Vec3::zeros();
        o[k] = point[k];
        o[i] = lo[i] + e;
        o[j] = lo[j] + e;
        let (mut du, mut dv) = (Vec3::zeros(), Vec3::zeros());
        du[i] = hi[i] - lo[i] - 2.0 * e;
        dv[j] = hi[j] - lo[j] - 2.0 * e;
        (o, du, dv)
    } else {
        let centre = 0.5 * (lo + hi);
        let p = centre - n * (centre - point).dot(&n);
        let side = (hi - lo).min() * (1.0 - 1e-6) / 2f64.sqrt();
        let a = if n.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
        let u = n.cross(&a).normalize() * side;
        let v = n.cross(&u);
        (p - 0.5 * (u + v), u, v)
    };
    const N: usize = 8;
    let mut nodes = Vec::with_capacity((N + 1) * (N + 1));
    for a in 0..=N {
        for b in 0..=N {
            nodes.push(origin + du * (a as f64 / N as f64) + dv * (b as f64 / N as f64));
        }
    }
    // counter-clockwise about n
    let ccw = du.cross(&dv).dot(&n) > 0.0;
    let mut tris = Vec::with_capacity(2 * N * N);
    for a in 0..N {
        for b in 0..N {
            let k = |x: usize, y: usize| (x * (N + 1) + y) as u32;
            let (p00, p10, p11, p01) = (k(a, b), k(a + 1, b), k(a + 1, b + 1), k(a, b + 1));
            if ccw {
                tris.push([p00, p10, p11]);
                tris.push([p00, p11, p01]);
            } else {
                tris.push([p00, p11, p10]);
                tris.push([p00, p01, p11]);
            }
        }
    }
    Mesh::new(nodes, tris).expect("a grid of squares is a valid mesh")
}

pub fn export(case: &Case, out: &Path, inserted: &[super::InsertedRow]) -> Result<Exported, TalusError> {
    let law = check(case)?;
    let sim = Simulation::new(case.clone())?;
    let dt = sim.dt();
    let skin = sim.state().nl.skin;
    let mut notes = Vec::new();
    if case.contact.convention != Convention::Liggghts {
        notes.push(format!(
            "the deck runs in LIGGGHTS's conventions; compare it with talus run with `--set contact.convention=liggghts` (the case says {:?})",
            case.contact.convention
        ));
    }
    let opts = {
        let mut c = case.contact.clone();
        c.convention = Convention::Liggghts;
        resolve(&c)
    };
    let nmat = case.materials.len();

    // particles: the data file
    let p = sim.particles();
    let mut idx: Vec<usize> = (0..p.owned()).collect();
    idx.sort_unstable_by_key(|&i| p.id[i]);
    let shift = if idx.first().is_some_and(|&i| p.id[i] == 0) { 1 } else { 0 };
    if shift == 1 {
        notes.push("talus ids start at 0: LIGGGHTS ids are talus ids + 1 (probe columns keep talus's ids)".into());
    }
    let d = &case.simulation.domain;
    let two_d = case.simulation.dimension == Dimension::Two;
    // ball walls: atoms after the particles
    let max_id = idx.iter().map(|&i| p.id[i] + shift).max().unwrap_or(0);
    let mut balls = Vec::new();
    for (i, w) in sim.walls().iter().enumerate() {
        if let Shape::Disc(dc) = &w.shape {
            let atom_type = case.material_index(&case.walls[i].material, "wall.material")? as usize + 1;
            balls.push((i, max_id + 1 + balls.len() as u64, dc.center, dc.radius, atom_type, Vec3::from(case.walls[i].velocity)));
        }
    }
    // inserted particles come in by create_atoms, which numbers them on from the
    // largest id: talus numbers them so too, with no gap
    if !inserted.is_empty() {
        if let Some(&(i, ..)) = balls.first() {
            return Err(refuse(case, &format!("wall.{}.disc", case.walls[i].name), "a ball wall is an atom whose id the inserted particles would take in LIGGGHTS"));
        }
        let mut ids: Vec<u64> = inserted.iter().map(|r| r.id + shift).collect();
        ids.sort_unstable();
        if ids.iter().enumerate().any(|(k, &id)| id != max_id + 1 + k as u64) {
            return Err(refuse(case, "--inserted", "the inserted particles' ids do not follow the case's on from its largest without a gap"));
        }
    }
    // the inserted particles by the step at whose start they came in
    let mut batches: Vec<(u64, Vec<&super::InsertedRow>)> = Vec::new();
    for r in inserted {
        match batches.last_mut() {
            Some((s, v)) if *s == r.step => v.push(r),
            _ => batches.push((r.step, vec![r])),
        }
    }
    batches.sort_by_key(|b| b.0);
    for (_, b) in batches.iter_mut() {
        b.sort_by_key(|r| r.id);
    }
    let create = |w: &mut String, step: u64, rows: &[&super::InsertedRow]| {
        let _ = writeln!(w, "# {} particles inserted by talus at the start of step {step} (its inserted.csv)", rows.len());
        for r in rows {
            let rho = case.materials[r.material as usize].density;
            let _ = writeln!(w, "create_atoms    {} single {} {} {} units box", r.material + 1, g(r.pos[0]), g(r.pos[1]), g(r.pos[2]));
            let _ = writeln!(
                w,
                "set             atom {} diameter {} density {} vx {} vy {} vz {}",
                r.id + shift,
                g(2.0 * r.radius),
                g(rho),
                g(r.vel[0]),
                g(r.vel[1]),
                g(r.vel[2])
            );
        }
        let (a, b) = (rows.first().map_or(0, |r| r.id + shift), rows.last().map_or(0, |r| r.id + shift));
        let _ = writeln!(w, "group           grains id {a}:{b}");
    };
    const BALL_DENSITY: f64 = 1e15;
    let mut data = String::new();
    let _ = writeln!(data, "LIGGGHTS data file: the initial particles of {} (exported by talus)\n", case.path.display());
    let _ = writeln!(data, "{} atoms\n{} atom types\n", idx.len() + balls.len(), nmat);
    for k in 0..3 {
        let _ = writeln!(data, "{} {} {}lo {}hi", g(d.lo[k]), g(d.hi[k]), ["x", "y", "z"][k], ["x", "y", "z"][k]);
    }
    data.push_str("\nAtoms\n\n");
    for &i in &idx {
        // in 2D LIGGGHTS takes the density per area (mass = pi r^2 rho): talus's mass is a sphere's
        let rho = if two_d {
            p.mass[i] / (std::f64::consts::PI * p.radius[i] * p.radius[i])
        } else {
            case.materials[p.material[i] as usize].density
        };
        let x = p.pos[i];
        let _ = writeln!(data, "{} {} {} {} {} {} {}", p.id[i] + shift, p.material[i] + 1, g(2.0 * p.radius[i]), g(rho), g(x.x), g(x.y), g(x.z));
    }
    for &(_, id, c, r, t, _) in &balls {
        let _ = writeln!(data, "{id} {t} {} {} {} {} {}", g(2.0 * r), g(BALL_DENSITY), g(c.x), g(c.y), g(c.z));
    }
    data.push_str("\nVelocities\n\n");
    for &i in &idx {
        let (v, w) = (p.vel[i], p.omega[i]);
        let _ = writeln!(data, "{} {} {} {} {} {} {}", p.id[i] + shift, g(v.x), g(v.y), g(v.z), g(w.x), g(w.y), g(w.z));
    }
    for &(_, id, _, _, _, v) in &balls {
        let _ = writeln!(data, "{id} {} {} {} 0 0 0", g(v.x), g(v.y), g(v.z));
    }
    let data_path = out.join("particles.data");
    std::fs::write(&data_path, data).map_err(|e| io(&data_path, e))?;
    let mut files = vec![out.join("in.talus"), data_path];

    // walls
    let (lo, hi) = (Vec3::from(d.lo), Vec3::from(d.hi));
    let mut walls = Vec::new();
    for (ws, w) in case.walls.iter().zip(sim.walls()) {
        let atom_type = case.material_index(&ws.material, "wall.material")? as usize + 1;
        let mut surface_vel = Vec3::zeros();
        let at = super::wall_motions(case, &ws.name);
        let still = at.iter().all(|m| m.is_still());
        let mut motions: Vec<Motion> = at.iter().map(Motion::from).collect();
        let mut axis_of = None;
        let kind = match &w.shape {
            Shape::Plane(pl) => {
                let n = pl.normal;
                let axis = (0..3).find(|&k| (n[k].abs() - 1.0).abs() < 1e-15 && (0..3).all(|j| j == k || n[j] == 0.0));
                match axis {
                    Some(axis) if still => Kind::Primitive { axis, at: pl.point[axis] },
                    _ => {
                        // the mesh moves along the normal (fix move/mesh); a single steady
                        // motion within the plane is its surface velocity
                        let along = |v: Vec3| (v - n * v.dot(&n)).norm() <= 1e-12 * v.norm();
                        for (m, a) in motions.iter_mut().zip(&at) {
                            if m.rotation.is_some() {
                                // (at rate 0 too: the deck gives no axis torque for a plane)
                                return Err(refuse(case, &format!("{}.rotation", a.key), PLANE_MOTION));
                            }
                            if m.oscillation.is_some_and(|o| !along(o.0)) {
                                return Err(refuse(case, &format!("{}.oscillation", a.key), PLANE_MOTION));
                            }
                            if !along(m.velocity) {
                                if at.len() > 1 || m.oscillation.is_some() {
                                    return Err(refuse(case, &format!("{}.velocity", a.key), PLANE_MOTION));
                                }
                                surface_vel = m.velocity - n * m.velocity.dot(&n);
                                m.velocity -= surface_vel;
                                // LIGGGHTS moves no mesh that has a surface velocity
                                if m.velocity != Vec3::zeros() {
                                    return Err(refuse(case, &format!("{}.velocity", a.key), PLANE_MOTION));
                                }
                            }
                            m.rotation = None;
                        }
                        let m = plane_mesh(pl.point, n, lo, hi);
                        let f = out.join("meshes").join(format!("{}.stl", ws.name));
                        std::fs::create_dir_all(out.join("meshes")).map_err(|e| io(&f, e))?;
                        m.write_stl(&f).map_err(|e| io(&f, e))?;
                        files.push(f);
                        notes.push(format!(
                            "wall {}: the plane is a mesh across the domain (LIGGGHTS's primitive planes stand still and are normal to an axis); it moves along its normal, and its motion within the plane is the mesh's surface velocity",
                            ws.name
                        ));
                        Kind::Mesh
                    }
                }
            }
            Shape::Mesh(m) => {
                // one axis of rotation per wall: the mesh's reference point is on it
                for (mo, a) in motions.iter().zip(&at) {
                    if let Some((ax, p, _)) = mo.rotation {
                        match axis_of {
                            None => axis_of = Some((p, ax)),
                            Some((p0, a0)) if p0 == p && a0 == ax => {}
                            Some(_) => {
                                return Err(refuse(case, &format!("{}.rotation", a.key), "the LIGGGHTS deck measures a wall's axis torque about one axis: every rotation of a wall must have the same axis and point"));
                            }
                        }
                    }
                }
                let f = out.join("meshes").join(format!("{}.stl", ws.name));
                std::fs::create_dir_all(out.join("meshes")).map_err(|e| io(&f, e))?;
                m.write_stl(&f).map_err(|e| io(&f, e))?;
                files.push(f);
                Kind::Mesh
            }
            Shape::Disc(_) => {
                if let Some(c) = cohesion_model(case)? {
                    return Err(refuse(case, &format!("contact.cohesion.model = \"{}\" with the ball wall {}", c.name(), ws.name), "a ball wall is an atom in the LIGGGHTS deck, whose cohesion takes the two-sphere area; talus's walls take the flat one"));
                }
                for (mo, a) in motions.iter().zip(&at) {
                    if mo.rotation.is_some() {
                        return Err(refuse(case, &format!("{}.rotation", a.key), "a ball wall is an atom moved by `fix move` in the LIGGGHTS deck: turning balls (and a ball's axis torque) are not written"));
                    }
                    if mo.oscillation.is_some() && mo.velocity != Vec3::zeros() {
                        return Err(refuse(case, &format!("{}.oscillation", a.key), "a ball wall is an atom moved by one `fix move` in the LIGGGHTS deck: it translates or oscillates, not both"));
                    }
                }
                let atom = balls.iter().find(|b| b.0 == walls.len()).expect("listed above").1;
                notes.push(format!(
                    "wall {}: the ball is atom {atom} of density {BALL_DENSITY:e} (m* = the particle's mass), moved by fix move and not integrated; its load is the force and torque on that atom",
                    ws.name
                ));
                Kind::Ball { atom }
            }
            _ => unreachable!("refused above"),
        };
        // (a plane that only slides within itself does not move: its surface velocity is written)
        let moves = |m: &Motion| m.velocity != Vec3::zeros() || m.oscillation.is_some() || m.rotation.is_some_and(|r| r.2 != 0.0);
        if still || matches!(kind, Kind::Primitive { .. }) || !motions.iter().any(moves) {
            motions.clear();
        }
        if matches!(kind, Kind::Mesh) && motions.iter().any(|m| m.oscillation.is_some()) {
            notes.push(format!(
                "wall {}: LIGGGHTS's `wiggle` moves the mesh by dt times its velocity at the step's end (a Riemann sum of A sin(w t), ahead of talus's exact displacement by about half a step: up to A w dt / 2), so the two differ by O(w dt): 0.2-0.4% in SC-wall's peak force and overlap with the plate at 2 kHz (w dt = 0.063), 0.1-0.2% at 500 Hz; translation and rotation agree to 1e-6 or better",
                ws.name
            ));
        }
        walls.push(W { name: ws.name.clone(), kind, atom_type, surface_vel, motions, axis: axis_of });
    }

    // the contact model words, shared by the pair style and the wall fixes
    let (model, settings) = match law {
        Law::Hertz => ("model hertz tangential history", String::new()),
        Law::HookeStiffness(_) => ("model hooke/stiffness tangential history", "absolute_damping on".to_string()),
        Law::HookeDerived(_) => ("model hooke tangential history", String::new()),
    };
    let settings = if opts.end == EndOfContact::Clip { format!("{settings} limitForce on").trim().to_string() } else { settings };
    // rolling resistance: LIGGGHTS's own cdt or epsd2 model, the coefficient per type pair (mean, as talus mixes it)
    let model = match case.contact.rolling {
        Some(crate::case::RollingModel::Cdt) => format!("{model} rolling_friction cdt"),
        Some(crate::case::RollingModel::Epsd2) => format!("{model} rolling_friction epsd2"),
        None => model.to_string(),
    };
    // cohesion: LIGGGHTS's own sjkr / sjkr2, the same on the pair style and every wall fix
    let model = match cohesion_model(case)? {
        Some(c) => format!("{model} cohesion {}", c.name()),
        None => model,
    };
    let model = model.as_str();

    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "# {} exported by talus {} for LIGGGHTS 3.8.0.", case.path.display(), env!("CARGO_PKG_VERSION"));
    let _ = writeln!(w, "# Run it in this folder:  liggghts -in in.talus -log log.liggghts");
    let _ = writeln!(w, "# It writes probes.csv with the columns of talus's probes.csv.");
    for n in &notes {
        let _ = writeln!(w, "# Note: {n}");
    }
    let header_notes = notes.len();
    let _ = writeln!(w, "\nunits           si\natom_style      granular\natom_modify     map array");
    // periodic axes as `p` (a 2D run is periodic across its thin z as LIGGGHTS wants)
    let b = |k: usize| if case.simulation.domain.is_periodic(k) { "p" } else { "f" };
    if two_d {
        let _ = writeln!(w, "dimension       2\nboundary        {} {} p", b(0), b(1));
    } else {
        let _ = writeln!(w, "boundary        {} {} {}", b(0), b(1), b(2));
    }
    let _ = writeln!(w, "newton          off\ncommunicate     single vel yes");
    if case.materials.iter().any(|m| m.youngs_modulus < 5e6) {
        let _ = writeln!(w, "soft_particles  yes                      # softer materials than LIGGGHTS's floor (5e6 Pa) are allowed");
    }
    if case.materials.iter().any(|m| m.youngs_modulus > 1e9) {
        let _ = writeln!(w, "hard_particles  yes                      # stiffer materials than LIGGGHTS's ceiling (1e9 Pa) are allowed");
    }
    if idx.is_empty() && balls.is_empty() {
        // no particles at the start (they are all inserted): LIGGGHTS reads no empty data file
        let _ = writeln!(
            w,
            "region          simbox block {} {} {} {} {} {} units box\ncreate_box      {nmat} simbox",
            g(d.lo[0]),
            g(d.hi[0]),
            g(d.lo[1]),
            g(d.hi[1]),
            g(d.lo[2]),
            g(d.hi[2])
        );
    } else {
        let _ = writeln!(w, "read_data       particles.data");
    }
    let _ = writeln!(w, "neighbor        {} bin\nneigh_modify    delay 0 every 1 check yes", g(skin));
    // the particles (not the ball walls): integrated, under gravity, in the energies
    let _ = writeln!(w, "group           grains id <= {max_id}");
    for x in &walls {
        if let Kind::Ball { atom } = x.kind {
            let _ = writeln!(w, "group           {}_g id {atom}", x.name);
        }
    }

    // materials: one atom type each; pairs as talus mixes them in LIGGGHTS's convention
    let list = |f: &dyn Fn(usize) -> f64| (0..nmat).map(|k| g(f(k))).collect::<Vec<_>>().join(" ");
    let _ = writeln!(w, "\n# materials: {}", case.materials.iter().map(|m| m.name.as_str()).collect::<Vec<_>>().join(", "));
    let _ = writeln!(w, "fix m1 all property/global youngsModulus peratomtype {}", list(&|k| case.materials[k].youngs_modulus));
    let _ = writeln!(w, "fix m2 all property/global poissonsRatio peratomtype {}", list(&|k| case.materials[k].poisson_ratio));
    let pair = |f: &dyn Fn(usize, usize) -> f64| {
        let mut v = Vec::new();
        for a in 0..nmat {
            for b in 0..nmat {
                v.push(g(f(a, b)));
            }
        }
        v.join(" ")
    };
    let mixed = |a: usize, b: usize| mix(&case.materials[a], &case.materials[b], Mixing::Liggghts);
    let _ = writeln!(w, "fix m3 all property/global coefficientRestitution peratomtypepair {nmat} {}", pair(&|a, b| mixed(a, b).restitution));
    let _ = writeln!(w, "fix m4 all property/global coefficientFriction peratomtypepair {nmat} {}", pair(&|a, b| mixed(a, b).friction));
    if cohesion_model(case)?.is_some() {
        let k = |a: usize, b: usize| case.contact.for_materials(&case.materials[a].name, &case.materials[b].name).cohesion.map_or(0.0, |c| c.energy_density);
        let _ = writeln!(w, "fix m7 all property/global cohesionEnergyDensity peratomtypepair {nmat} {}", pair(&k));
    }
    if case.contact.rolling.is_some() {
        notes.push("rolling resistance: a primitive wall's torque column is the moment of the contact forces only (talus's also takes the rolling torques' reaction)".into());
        let _ = writeln!(w, "fix m6 all property/global coefficientRollingFriction peratomtypepair {nmat} {}", pair(&|a, b| mixed(a, b).rolling_friction));
    }
    match law {
        Law::HookeStiffness(k) => {
            let _ = writeln!(w, "fix k1 all property/global kn peratomtypepair {nmat} {}", pair(&|_, _| k.kn));
            let _ = writeln!(w, "fix k2 all property/global kt peratomtypepair {nmat} {}", pair(&|_, _| k.kt));
            let _ = writeln!(w, "fix k3 all property/global gamman_abs peratomtypepair {nmat} {}", pair(&|_, _| k.gamma_n));
            let _ = writeln!(w, "fix k4 all property/global gammat_abs peratomtypepair {nmat} {}", pair(&|_, _| k.gamma_t));
        }
        Law::HookeDerived(v) => {
            let _ = writeln!(w, "fix m5 all property/global characteristicVelocity scalar {}", g(v));
        }
        Law::Hertz => {}
    }
    let _ = writeln!(w, "pair_style      gran {model} {settings}\npair_coeff      * *\ntimestep        {}", g(dt));
    let gv = Vec3::from(case.simulation.gravity);
    if gv.norm() > 0.0 {
        let u = gv / gv.norm();
        let _ = writeln!(w, "fix gravi grains gravity {} vector {} {} {}", g(gv.norm()), g(u.x), g(u.y), g(u.z));
    }

    // walls
    let meshes: Vec<&W> = walls.iter().filter(|x| matches!(x.kind, Kind::Mesh)).collect();
    let _ = writeln!(w, "\n# ---- walls (f_NAME[1..3]: force of the particles on a mesh, [4..6] torque about the origin)");
    for m in &meshes {
        let sv = if m.surface_vel != Vec3::zeros() {
            format!(" surface_vel {} {} {}", g(m.surface_vel.x), g(m.surface_vel.y), g(m.surface_vel.z))
        } else {
            String::new()
        };
        let rp = match m.axis {
            Some((p, _)) => format!(" reference_point {} {} {}", g(p.x), g(p.y), g(p.z)),
            None => String::new(),
        };
        let _ = writeln!(w, "fix {0} all mesh/surface/stress file meshes/{0}.stl type {1}{sv}{rp}", m.name, m.atom_type);
    }
    let mesh_fix = |w: &mut String, names: &[&str]| {
        if !names.is_empty() {
            let _ = writeln!(w, "fix meshes all wall/gran {model} mesh n_meshes {} meshes {} {settings}", names.len(), names.join(" "));
            let _ = writeln!(w, "compute wgl all wall/gran/local id\ncompute wgl_sum all reduce sum c_wgl[3]\ncompute wgl_ave all reduce ave c_wgl[3]");
            let _ = writeln!(w, "variable n_mesh equal floor(c_wgl_sum/(c_wgl_ave+(c_wgl_ave==0))+0.5)");
        } else {
            let _ = writeln!(w, "variable n_mesh equal 0");
        }
    };
    let mut live: Vec<bool> = vec![true; walls.len()];
    let mesh_names = |live: &[bool]| -> Vec<&str> {
        walls.iter().zip(live).filter(|(x, l)| **l && matches!(x.kind, Kind::Mesh)).map(|(x, _)| x.name.as_str()).collect()
    };
    mesh_fix(w, &mesh_names(&live));
    for x in &walls {
        if let Kind::Primitive { axis, at } = x.kind {
            let plane = ["xplane", "yplane", "zplane"][axis];
            let _ = writeln!(w, "fix {} all wall/gran {model} primitive type {} {plane} {} store_force yes {settings}", x.name, x.atom_type, g(at));
        }
    }
    let _ = writeln!(w, "fix integr grains nve/sphere");
    if two_d {
        let _ = writeln!(w, "fix e2d all enforce2d");
    }
    // the walls' motions from the start: a ball by `fix move` (linear or wiggle), a
    // mesh by `fix move/mesh` (active fix ids per wall, to unfix when a phase changes them)
    let ball_move = |w: &mut String, name: &str, m: Option<&Motion>| {
        let v = m.map_or(Vec3::zeros(), |m| m.velocity);
        match m.and_then(|m| m.oscillation) {
            Some((a, f)) => {
                let _ = writeln!(w, "fix {name}_move {name}_g move wiggle {} {} {} {}", g(a.x), g(a.y), g(a.z), g(1.0 / f));
            }
            None => {
                let _ = writeln!(w, "fix {name}_move {name}_g move linear {} {} {}", g(v.x), g(v.y), g(v.z));
            }
        }
    };
    let mut moving: Vec<Vec<String>> = vec![Vec::new(); walls.len()];
    for (i, x) in walls.iter().enumerate() {
        match x.kind {
            Kind::Ball { .. } => ball_move(w, &x.name, x.motions.first()),
            Kind::Mesh => {
                if let Some(m) = x.motions.first() {
                    mesh_moves(w, &x.name, m, &mut moving[i]);
                }
            }
            Kind::Primitive { .. } => {}
        }
    }

    // probes
    let _ = writeln!(w, "\n# ---- probes: the columns of talus's probes.csv");
    let _ = writeln!(w, "variable t equal step*{}\nvariable st equal step", g(dt));
    let _ = writeln!(w, "compute ke_t grains ke\ncompute ke_r grains erotate/sphere\nvariable ke equal c_ke_t+c_ke_r");
    let _ = writeln!(w, "variable pe_atom atom -mass*({}*x+{}*y+{}*z)\ncompute pe_sum grains reduce sum v_pe_atom\nvariable pe equal c_pe_sum", g(gv.x), g(gv.y), g(gv.z));
    if !balls.is_empty() {
        let _ = writeln!(w, "compute tqa all property/atom tqx tqy tqz");
    }
    let _ = writeln!(w, "compute radius all property/atom radius");
    let _ = writeln!(w, "compute pc all contact/atom\ncompute pc_sum all reduce sum c_pc\nvariable n_pair equal floor(c_pc_sum/2+0.5)");
    let wall_vars = |w: &mut String, x: &W, on: bool| {
        let n = &x.name;
        if !on {
            for q in ["fx", "fy", "fz", "tx", "ty", "tz"] {
                let _ = writeln!(w, "variable {n}_{q} equal 0");
            }
            if x.axis.is_some() {
                let _ = writeln!(w, "variable {n}_ta equal 0");
            }
            let _ = writeln!(w, "variable {n}_n equal 0");
            return;
        }
        match x.kind {
            Kind::Mesh if x.motions.is_empty() && x.axis.is_none() => {
                for (k, q) in ["fx", "fy", "fz", "tx", "ty", "tz"].iter().enumerate() {
                    let _ = writeln!(w, "variable {n}_{q} equal f_{n}[{}]", k + 1);
                }
            }
            Kind::Mesh => {
                // f_NAME[4..6] is the torque about the mesh's reference point, which moves
                // with it (now at f_NAME[7..9]): about the origin, T + p x F
                let f = |k: usize| format!("f_{n}[{k}]");
                for (k, q) in ["fx", "fy", "fz"].iter().enumerate() {
                    let _ = writeln!(w, "variable {n}_{q} equal {}", f(k + 1));
                }
                let _ = writeln!(w, "variable {n}_tx equal {}+{}*{}-{}*{}", f(4), f(8), f(3), f(9), f(2));
                let _ = writeln!(w, "variable {n}_ty equal {}+{}*{}-{}*{}", f(5), f(9), f(1), f(7), f(3));
                let _ = writeln!(w, "variable {n}_tz equal {}+{}*{}-{}*{}", f(6), f(7), f(2), f(8), f(1));
                if let Some((_, a)) = x.axis {
                    let _ = writeln!(w, "variable {n}_ta equal {}*{}+{}*{}+{}*{}", f(4), g(a.x), f(5), g(a.y), f(6), g(a.z));
                }
            }
            Kind::Ball { atom } => {
                // the force of the particles on the ball is the force on its atom; the torque
                // about the origin x x f plus the torque of the contacts about its centre
                let _ = writeln!(w, "compute {n}_sum {n}_g reduce sum fx fy fz c_tqa[1] c_tqa[2] c_tqa[3]");
                for (k, q) in ["fx", "fy", "fz"].iter().enumerate() {
                    let _ = writeln!(w, "variable {n}_{q} equal c_{n}_sum[{}]", k + 1);
                }
                let (f, t) = (|k: usize| format!("c_{n}_sum[{}]", k + 1), |k: usize| format!("c_{n}_sum[{}]", k + 4));
                let _ = writeln!(w, "variable {n}_tx equal y[{atom}]*{}-z[{atom}]*{}+{}", f(2), f(1), t(0));
                let _ = writeln!(w, "variable {n}_ty equal z[{atom}]*{}-x[{atom}]*{}+{}", f(0), f(2), t(1));
                let _ = writeln!(w, "variable {n}_tz equal x[{atom}]*{}-y[{atom}]*{}+{}", f(1), f(0), t(2));
            }
            Kind::Primitive { axis, at } => {
                // force of the particles on the plane = - sum of its force on them; torque
                // about the origin at the contact point, the middle of the overlap on the
                // normal through the centre (as talus in LIGGGHTS's convention)
                let mut c = ["x".to_string(), "y".to_string(), "z".to_string()];
                let (q, a) = (["x", "y", "z"][axis], g(at));
                c[axis] = format!("({a}-({q}-{a})/abs({q}-{a})*(c_radius-abs({q}-{a}))/2)");
                let f = |k: usize| format!("f_force_{n}[{}]", k + 1);
                let _ = writeln!(w, "variable {n}_on atom ({}!=0)||({}!=0)||({}!=0)", f(0), f(1), f(2));
                let _ = writeln!(w, "variable {n}_tx_atom atom -({}*{}-{}*{})", c[1], f(2), c[2], f(1));
                let _ = writeln!(w, "variable {n}_ty_atom atom -({}*{}-{}*{})", c[2], f(0), c[0], f(2));
                let _ = writeln!(w, "variable {n}_tz_atom atom -({}*{}-{}*{})", c[0], f(1), c[1], f(0));
                let _ = writeln!(w, "compute {n}_sum all reduce sum {} {} {} v_{n}_on v_{n}_tx_atom v_{n}_ty_atom v_{n}_tz_atom", f(0), f(1), f(2));
                for (k, q) in ["fx", "fy", "fz"].iter().enumerate() {
                    let _ = writeln!(w, "variable {n}_{q} equal 0-c_{n}_sum[{}]", k + 1);
                }
                for (k, q) in ["tx", "ty", "tz"].iter().enumerate() {
                    let _ = writeln!(w, "variable {n}_{q} equal c_{n}_sum[{}]", k + 5);
                }
                let _ = writeln!(w, "variable {n}_n equal floor(c_{n}_sum[4]+0.5)");
            }
        }
    };
    let contacts = |w: &mut String, live: &[bool]| {
        let mut terms = vec!["v_n_pair".to_string(), "v_n_mesh".to_string()];
        for (x, l) in walls.iter().zip(live) {
            if *l && matches!(x.kind, Kind::Primitive { .. }) {
                terms.push(format!("v_{}_n", x.name));
            }
        }
        let _ = writeln!(w, "variable contacts equal {}", terms.join("+"));
    };
    for x in &walls {
        wall_vars(w, x, true);
    }
    contacts(w, &live);
    let mut header = String::from("time_s,step,phase,kinetic_energy_j,contacts");
    let mut row = String::from("${t},${st},${phase},${ke},${contacts}");
    let mut thermo = String::from("step v_t v_ke v_pe v_contacts");
    // a case that inserts particles reports how many are in, as talus does
    if case.phases.iter().any(|p| !p.inserts.is_empty()) {
        let _ = writeln!(w, "variable np equal count(grains)");
        header.push_str(",particles");
        row.push_str(",${np}");
        thermo.push_str(" v_np");
    }
    for x in &walls {
        for c in ["x", "y", "z"] {
            let _ = write!(header, ",{}_force_{c}_n", x.name);
            let _ = write!(row, ",${{{}_f{c}}}", x.name);
            let _ = write!(thermo, " v_{}_f{c}", x.name);
        }
        for c in ["x", "y", "z"] {
            let _ = write!(header, ",{}_torque_{c}_n_m", x.name);
            let _ = write!(row, ",${{{}_t{c}}}", x.name);
            let _ = write!(thermo, " v_{}_t{c}", x.name);
        }
        if x.axis.is_some() {
            let _ = write!(header, ",{}_axis_torque_n_m", x.name);
            let _ = write!(row, ",${{{}_ta}}", x.name);
            let _ = write!(thermo, " v_{}_ta", x.name);
        }
    }
    super::lammps_family_columns(case, w, &mut header, &mut row, &mut thermo);
    for &id in &case.output.track {
        let l = id + shift;
        for (q, v) in [
            ("x_m", "x"), ("y_m", "y"), ("z_m", "z"), ("vx_m_s", "vx"), ("vy_m_s", "vy"), ("vz_m_s", "vz"),
            ("wx_rad_s", "omegax"), ("wy_rad_s", "omegay"), ("wz_rad_s", "omegaz"), ("fx_n", "fx"), ("fy_n", "fy"), ("fz_n", "fz"),
        ] {
            let _ = writeln!(w, "variable p{id}_{q} equal {v}[{l}]");
            let _ = write!(header, ",p{id}_{q}");
            let _ = write!(row, ",${{p{id}_{q}}}");
        }
    }
    let every = super::probe_every(case, dt, &mut notes);
    let first = case.phases.first().map(|p| p.name.as_str()).unwrap_or("end");
    let _ = writeln!(w, "variable phase string {first}");
    let _ = writeln!(w, "thermo_style    custom {thermo}\nthermo          {every}\nthermo_modify   lost error norm no");
    // particles inserted at the start of step 0 are there before the first run
    while batches.first().is_some_and(|b| b.0 == 0) {
        let (st, rows) = batches.remove(0);
        create(w, st, &rows);
    }
    let _ = writeln!(w, "\n# step 0: forces at the start (run 0 moves nothing), the first row, the reference PE");
    let _ = writeln!(w, "fix probe all print {every} \"{row}\" append probes.csv screen no title none");
    let _ = writeln!(w, "run             0 post no");
    let _ = writeln!(w, "print \"{header}\" file probes.csv screen no");
    let _ = writeln!(w, "print \"{row}\" append probes.csv screen no");
    let _ = writeln!(w, "variable pe0 equal ${{pe}}");
    let _ = writeln!(w, "variable pre string no");

    // phases
    let mut s0: Option<u64> = Some(0);
    // walls removed at a time: (step, wall index), in step order
    let mut timed: Vec<(u64, usize)> = case
        .walls
        .iter()
        .enumerate()
        .filter_map(|(i, x)| x.remove_at.map(|t| (removal_step(t, dt), i)))
        .collect();
    timed.sort();
    let remove = |w: &mut String, live: &mut Vec<bool>, moving: &mut Vec<Vec<String>>, i: usize, why: &str| {
        if !live[i] {
            return;
        }
        // (superposed moves are unfixed newest first)
        for id in moving[i].drain(..).rev() {
            let _ = writeln!(w, "unfix {id}");
        }
        let x = &walls[i];
        let _ = writeln!(w, "# remove wall {} ({why})", x.name);
        wall_vars(w, x, false);
        match x.kind {
            Kind::Primitive { .. } => {
                let _ = writeln!(w, "uncompute {0}_sum\nunfix {0}", x.name);
                live[i] = false;
            }
            Kind::Ball { .. } => {
                let _ = writeln!(w, "uncompute {0}_sum\nunfix {0}_move\ndelete_atoms group {0}_g", x.name);
                live[i] = false;
            }
            Kind::Mesh => {
                let had = !mesh_names(live).is_empty();
                if had {
                    let _ = writeln!(w, "uncompute wgl_ave\nuncompute wgl_sum\nuncompute wgl\nunfix meshes");
                }
                let _ = writeln!(w, "unfix {}", x.name);
                live[i] = false;
                let _ = writeln!(w, "# the mesh fix again without it: contacts with the other meshes restart without history");
                mesh_fix(w, &mesh_names(live));
            }
        }
        contacts(w, live);
        let _ = writeln!(w, "variable pre string yes");
    };
    for (k, ph) in case.phases.iter().enumerate() {
        let _ = writeln!(w, "\n# ---- phase {k}: {} ({} s{})", ph.name, ph.duration, if ph.kinetic_energy_fraction.is_some() { ", or settled" } else { "" });
        let _ = writeln!(w, "variable phase string {}", ph.name);
        // the walls whose motion this phase changes (set-up again before its first run)
        for (i, x) in walls.iter().enumerate() {
            let Some(m) = x.motions.iter().find(|m| m.phase == k && k > 0) else { continue };
            if !live[i] {
                continue;
            }
            let _ = writeln!(w, "# wall {}: its motion from here", x.name);
            match x.kind {
                Kind::Ball { .. } => {
                    let _ = writeln!(w, "unfix {}_move", x.name);
                    ball_move(w, &x.name, Some(m));
                }
                Kind::Mesh => {
                    for id in moving[i].drain(..).rev() {
                        let _ = writeln!(w, "unfix {id}");
                    }
                    mesh_moves(w, &x.name, m, &mut moving[i]);
                }
                Kind::Primitive { .. } => {}
            }
            let _ = writeln!(w, "variable pre string yes");
        }
        match (ph.kinetic_energy_fraction, s0) {
            (None, Some(start)) => {
                let n = phase_steps(start, ph.duration, dt);
                let end = start + n;
                let mut at = start;
                loop {
                    // the next wall removed at a time, or batch of inserted particles, in this phase
                    let rs = timed.first().map(|x| x.0).filter(|&rs| rs <= end && rs >= at);
                    let bs = batches.first().map(|x| x.0).filter(|&bs| bs < end && bs >= at);
                    let Some(next) = rs.into_iter().chain(bs).min() else { break };
                    if next > at {
                        let _ = writeln!(w, "run             {} pre ${{pre}} post no\nvariable pre string no", next - at);
                        at = next;
                    }
                    if rs == Some(next) {
                        let i = timed.remove(0).1;
                        remove(w, &mut live, &mut moving, i, &format!("remove_at = {} s", case.walls[i].remove_at.unwrap_or(0.0)));
                    } else {
                        let (st, rows) = batches.remove(0);
                        create(w, st, &rows);
                        // new atoms: the run sets up again
                        let _ = writeln!(w, "variable pre string yes");
                    }
                }
                if end > at {
                    let _ = writeln!(w, "run             {} pre ${{pre}} post no\nvariable pre string no", end - at);
                }
                s0 = Some(end);
            }
            (None, None) => {
                if !batches.is_empty() {
                    return Err(refuse(case, &format!("phase.{}.insert", ph.name), "particles inserted after a phase that ends on kinetic energy: the step is not known when the deck is written"));
                }
                if timed.iter().any(|_| true) {
                    return Err(refuse(case, "wall.remove_at", "a wall removed at a time after a phase that ends on kinetic energy: the step is not known when the deck is written"));
                }
                let n = (ph.duration / dt - 0.5).ceil().max(0.0) as u64;
                let _ = writeln!(w, "run             {n} pre ${{pre}} post no\nvariable pre string no");
            }
            (Some(frac), _) => {
                if !batches.is_empty() {
                    return Err(refuse(case, &format!("phase.{}.insert", ph.name), "particles inserted during or after a phase that ends on kinetic energy: the step is not known when the deck is written"));
                }
                if timed.iter().any(|&(rs, _)| s0.is_none_or(|a| rs >= a)) {
                    return Err(refuse(case, &format!("phase[{k}].kinetic_energy_fraction"), "a wall removed at a time during or after a phase that ends on kinetic energy: the step is not known when the deck is written"));
                }
                let nmax = match s0 {
                    Some(a) => phase_steps(a, ph.duration, dt),
                    None => (ph.duration / dt - 0.5).ceil().max(0.0) as u64,
                };
                let settle = (ph.settle_extra / dt - 0.5).ceil().max(0.0) as u64;
                let p = format!("ph{k}");
                let _ = writeln!(w, "# chunks to each multiple of 20 steps; between them the test KE < {frac:e} (PE0 - PE)");
                let _ = writeln!(w, "variable {p}_end equal ${{st}}+{nmax}");
                let _ = writeln!(w, "label {p}_loop");
                let _ = writeln!(w, "if \"${{st}} >= ${{{p}_end}}\" then \"jump SELF {p}_done\"");
                let _ = writeln!(w, "variable {p}_m equal ${{st}}-20*floor(${{st}}/20)");
                // (the `if` of this LAMMPS base compares numbers only: the test is a variable)
                let _ = writeln!(w, "variable {p}_test equal (v_{p}_m==0)&&(v_pe0-v_pe>0)&&(v_ke<{}*(v_pe0-v_pe))", g(frac));
                let _ = writeln!(w, "if \"${{{p}_test}} == 1\" then \"jump SELF {p}_settled\"");
                let _ = writeln!(w, "variable {p}_a equal 20-${{{p}_m}}");
                let _ = writeln!(w, "variable {p}_b equal ${{{p}_end}}-${{st}}");
                let _ = writeln!(w, "variable {p}_n equal ${{{p}_a}}+(${{{p}_b}}<${{{p}_a}})*(${{{p}_b}}-${{{p}_a}})");
                let _ = writeln!(w, "run             ${{{p}_n}} pre ${{pre}} post no\nvariable pre string no");
                let _ = writeln!(w, "jump SELF {p}_loop");
                let _ = writeln!(w, "label {p}_settled");
                let _ = writeln!(w, "print \"phase {}: settled at step ${{st}}; {settle} steps more\"", ph.name);
                let _ = writeln!(w, "variable {p}_b equal ${{{p}_end}}-${{st}}");
                let _ = writeln!(w, "variable {p}_n equal {settle}+(${{{p}_b}}<{settle})*(${{{p}_b}}-{settle})");
                let _ = writeln!(w, "run             ${{{p}_n}} pre ${{pre}} post no\nvariable pre string no");
                let _ = writeln!(w, "label {p}_done");
                s0 = None;
            }
        }
        for name in &ph.remove_walls_at_end {
            if let Some(i) = walls.iter().position(|x| &x.name == name) {
                remove(w, &mut live, &mut moving, i, &format!("end of phase {}", ph.name));
            }
        }
    }
    if case.output.final_state {
        // (ids in the dump are LIGGGHTS's: talus's + the shift above)
        let _ = writeln!(w, "\n# output.final_state: every particle at the end");
        let _ = writeln!(w, "dump fin all custom 1 final.dump id x y z vx vy vz radius\ndump_modify fin sort id");
        let _ = writeln!(w, "run             0 post no\nundump fin");
    }
    let _ = writeln!(w, "\nprint \"talus export: done at step ${{st}}\"");
    for n in notes.iter().skip(header_notes) {
        let _ = writeln!(w, "# Note: {n}");
    }
    let deck = out.join("in.talus");
    std::fs::write(&deck, s).map_err(|e| io(&deck, e))?;
    Ok(Exported { files, command: format!("cd {} && liggghts -in in.talus -log log.liggghts", out.display()), notes })
}
