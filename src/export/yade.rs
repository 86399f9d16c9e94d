//! A case as a YADE 2023 script (`talus.py`), with its particle file and
//! meshes, writing `probes.csv` with talus's columns on talus's row steps.
//!
//! The script is in YADE's conventions (talus with `contact.convention =
//! "yade"` runs the same equations): Hertz-Mindlin (`FrictMat`,
//! `Ip2_FrictMat_FrictMat_MindlinPhys` with talus's mixed restitution per
//! material pair as `en`/`es` MatchMakers, since YADE does not mix e) or
//! Hooke (`ViscElMat` with constants per material that YADE's series
//! combination turns back into talus's pair constants). It is laid out as:
//!
//! - `talus.py`: the case as JSON (`C = ...`, numbers written to round-trip)
//!   followed by one fixed driver, `yade_driver.py`, which builds the scene,
//!   writes the probes from a `PyRunner` between the force loop and the
//!   integrator, and runs the phases in `O.run` chunks with talus's step rules;
//! - `particles.csv`: the very particles talus starts from (a lattice cloud
//!   included), with talus's masses and moments of inertia;
//! - `meshes/NAME.stl`: every STL wall as loaded.
//!
//! The design, with the sources each rule was read from, is in
//! ARCHITECTURE.md, "Exporting to YADE".

use super::{refuse, Exported};
use crate::case::{Case, ModelName, WallContactPoint, WallShape};
use crate::contact::conventions::resolve;
use crate::contact::hertz::HertzDamping;
use crate::contact::hooke::Hooke;
use crate::contact::{Convention, EndOfContact, FrictionCap, PairInertia, ShearKinematics, TangentialHistory};
use crate::dim::{Dimension, Vec3};
use crate::error::TalusError;
use crate::integrate::IntegratorKind;
use crate::material::{mix, Mixing};
use crate::sim::Simulation;
use crate::walls::Shape;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

const DRIVER: &str = include_str!("yade_driver.py");

fn io(path: &Path, e: std::io::Error) -> TalusError {
    TalusError::io(format!("writing {}", path.display()), e)
}

/// Refuse what the YADE script cannot reproduce, naming the key.
fn check(case: &Case) -> Result<(), TalusError> {
    let s = &case.simulation;
    if s.integrator == IntegratorKind::Gear {
        return Err(refuse(case, "simulation.integrator = \"gear\"", "YADE's NewtonIntegrator is leapfrog; the export reproduces velocity Verlet only"));
    }
    if !case.particles.ellipses.is_empty() {
        return Err(refuse(case, "particles.ellipses", "YADE has no 2D ellipse with talus's contact geometry"));
    }
    if !s.domain.periodic.is_empty() {
        if let Some(w) = case.walls.first() {
            return Err(refuse(
                case,
                &format!("wall.{} in a periodic domain", w.name),
                "YADE's periodic cell takes no wall across it (its collider asserts that every body is shorter than half the cell; measured with YADE 2023.02a): only a periodic case without walls is exported",
            ));
        }
    }
    let c = &case.contact;
    // every model and option decided here, by name (a new one does not
    // compile until it is)
    if let Some(pr) = c.pairs.first() {
        return Err(refuse(case, &format!("contact.pair (materials {:?})", pr.materials), "the YADE export writes one law for every pair of materials; compare laws per pair of materials against LAMMPS (--engines talus,lammps)"));
    }
    let hertz = match c.model {
        ModelName::Hertz => true,
        ModelName::Hooke => false,
        m @ (ModelName::Dmt | ModelName::Jkr) => {
            return Err(refuse(
                case,
                &format!("contact.model = \"{}\"", m.name()),
                "the YADE export writes Hertz-Mindlin or ViscEl without adhesion (YADE's Mindlin DMT caps friction and damps the pull its own way); compare dmt and jkr against LAMMPS (--engines talus,lammps)",
            ))
        }
    };
    match (hertz, c.damping) {
        (_, None) | (true, Some(HertzDamping::Yade)) => {}
        (false, Some(d)) => {
            return Err(refuse(case, &format!("contact.damping = \"{}\"", d.name()), "the hooke law takes no hertz damping mapping"));
        }
        (true, Some(d @ (HertzDamping::Liggghts | HertzDamping::Tsuji))) => {
            return Err(refuse(
                case,
                &format!("contact.damping = \"{}\"", d.name()),
                "the script maps restitution as YADE's Mindlin does (Thornton's fit); another damping mapping is not exported to YADE",
            ));
        }
    }
    match c.end_of_contact {
        None | Some(EndOfContact::Clip) => {}
        Some(EndOfContact::Tensile) => {
            return Err(refuse(case, "contact.end_of_contact = \"tensile\"", "YADE's laws clip the normal force at zero"));
        }
    }
    match c.tangential {
        None | Some(TangentialHistory::Incremental) => {}
        Some(t @ (TangentialHistory::Total | TangentialHistory::Rescaled)) => {
            return Err(refuse(case, &format!("contact.tangential = \"{}\"", t.name()), "YADE's laws increment the shear force"));
        }
    }
    match c.friction_cap {
        None | Some(FrictionCap::Total) => {}
        Some(f @ (FrictionCap::Elastic | FrictionCap::Pulloff)) => {
            return Err(refuse(case, &format!("contact.friction_cap = \"{}\"", f.name()), "YADE caps friction with the total normal force"));
        }
    }
    match (hertz, c.shear_kinematics) {
        (_, None) | (true, Some(ShearKinematics::FullRadii)) | (false, Some(ShearKinematics::ContactPoint)) => {}
        (true, Some(k @ (ShearKinematics::ContactPoint | ShearKinematics::Radii))) => {
            return Err(refuse(case, &format!("contact.shear_kinematics = \"{}\"", k.name()), "YADE's Mindlin drives the shear spring with the full radii and its alpha factor (ScGeom's shearIncrement)"));
        }
        (false, Some(k @ (ShearKinematics::FullRadii | ShearKinematics::Radii))) => {
            return Err(refuse(case, &format!("contact.shear_kinematics = \"{}\"", k.name()), "YADE's ViscEl law drives the shear spring by the contact point's velocity"));
        }
    }
    if let Some(coh) = &c.cohesion {
        return Err(refuse(
            case,
            &format!("contact.cohesion.model = \"{}\"", coh.model.name()),
            "YADE 2023 has no simplified-JKR cohesion (a force proportional to the overlap's area); its Mindlin adhesion is DMT's constant pull-off",
        ));
    }
    if c.rolling.is_some() {
        let why = match c.rolling {
            Some(crate::case::RollingModel::Epsd2) => "YADE 2023's Hertz-Mindlin law has no elastic-plastic rolling spring capped at mu_r F_n R (its rolling moment, Law2_ScGeom6D_CohFrictPhys_CohesionMoment, comes with a linear normal law)",
            _ => "YADE 2023's Mindlin and ViscEl laws have no constant directional rolling torque (ViscEl's moment resistance grows with the spin)",
        };
        return Err(refuse(case, "contact.rolling", why));
    }
    for w in &case.walls {
        // YADE's axis-aligned `Wall` bodies (a plane normal to x, y or z; a 2D box) cannot turn
        let aligned = match &w.shape {
            WallShape::Plane(pl) => (0..3).any(|k| (pl.normal[k].abs() - 1.0).abs() < 1e-15 && (0..3).all(|q| q == k || pl.normal[q] == 0.0)),
            WallShape::Box(_) => true,
            _ => false,
        };
        for m in super::wall_motions(case, &w.name) {
            if aligned && m.rotation.is_some_and(|r| r.angular_velocity != 0.0) {
                return Err(refuse(case, &format!("{}.rotation", m.key), "a plane normal to x, y or z (or a 2D box) is a YADE `Wall`, which cannot turn; give a turning wall as an STL mesh"));
            }
        }
    }
    for (i, w) in case.walls.iter().enumerate() {
        if let WallShape::Segment(_) = w.shape {
            return Err(refuse(case, &format!("wall[{i}].segment ({})", w.name), "YADE has no 2D segment wall with rounded ends; give the wall as a plane or a box"));
        }
    }
    Ok(())
}

/// ViscElMat constants per material such that YADE's series combination
/// 1/(1/a + 1/b) (0 meaning absent) gives back talus's pair constants:
/// `pp` between particles (None with a single particle), `pw[i]` against wall i.
/// Returns (particle constant, wall constants), or the wall that cannot be made.
fn series_split(pp: Option<f64>, pw: &[f64]) -> Result<(f64, Vec<f64>), usize> {
    let p = match pp {
        None => 0.0,
        Some(x) => 2.0 * x,
    };
    let mut w = Vec::with_capacity(pw.len());
    for (i, &x) in pw.iter().enumerate() {
        if p == 0.0 {
            w.push(x);
        } else if x == p {
            w.push(0.0);
        } else if x > 0.0 && x < p {
            w.push(1.0 / (1.0 / x - 1.0 / p));
        } else {
            return Err(i);
        }
    }
    Ok((p, w))
}

/// YADE's combination of two ViscElMat constants.
#[cfg(test)]
fn combine(a: f64, b: f64) -> f64 {
    let s = (if a != 0.0 { 1.0 / a } else { 0.0 }) + (if b != 0.0 { 1.0 / b } else { 0.0 });
    if s != 0.0 {
        1.0 / s
    } else {
        0.0
    }
}

pub fn export(case: &Case, out: &Path, inserted: &[super::InsertedRow]) -> Result<Exported, TalusError> {
    check(case)?;
    let sim = Simulation::new(case.clone())?;
    let dt = sim.dt();
    let skin = sim.state().nl.skin;
    let two_d = case.simulation.dimension == Dimension::Two;
    let hertz = case.contact.model == ModelName::Hertz;
    let mut notes = Vec::new();
    if case.contact.convention != Convention::Yade {
        notes.push(format!(
            "the script runs in YADE's conventions; compare it with talus run with `--set contact.convention=yade` (the case says {:?})",
            case.contact.convention
        ));
    }
    let opts = {
        let mut c = case.contact.clone();
        c.convention = Convention::Yade;
        resolve(&c)
    };
    let nmat = case.materials.len();
    let p = sim.particles();
    let mut idx: Vec<usize> = (0..p.owned()).collect();
    idx.sort_unstable_by_key(|&i| p.id[i]);

    // clumps: equal members only (YADE turns a clump about its centre of mass)
    let cl = &sim.state().clumps;
    let mut clumps = Vec::new();
    for k in 0..cl.members.len() {
        let [a, b] = cl.members[k];
        if p.radius[a] != p.radius[b] || p.mass[a] != p.mass[b] {
            return Err(refuse(case, &format!("particles.clumps[{k}]"), "YADE turns a clump about its centre of mass, talus about the midpoint of the two centres: the members must be equal"));
        }
        clumps.push(json!({
            "members": [p.id[a], p.id[b]],
            "vel": [cl.vel[k].x, cl.vel[k].y, cl.vel[k].z],
            "omega_z": cl.omega[k],
            "mass": cl.mass[k],
            "inertia": cl.inertia[k],
        }));
    }

    // particles.csv
    let mut csv = String::from("id,material,x,y,z,radius,mass,inertia,vx,vy,vz,wx,wy,wz\n");
    for &i in &idx {
        let (x, v, w) = (p.pos[i], p.vel[i], p.omega[i]);
        let _ = writeln!(
            csv,
            "{},{},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?},{:?}",
            p.id[i],
            p.material[i],
            x.x,
            x.y,
            x.z,
            p.radius[i],
            p.mass[i],
            1.0 / p.inv_inertia[i],
            v.x,
            v.y,
            v.z,
            w.x,
            w.y,
            w.z
        );
    }
    let csv_path = out.join("particles.csv");
    std::fs::write(&csv_path, csv).map_err(|e| io(&csv_path, e))?;
    let mut files = vec![out.join("talus.py"), csv_path];

    // walls
    let d = &case.simulation.domain;
    let (lo, hi) = (Vec3::from(d.lo), Vec3::from(d.hi));
    let duration: f64 = case.phases.iter().map(|ph| ph.duration).sum();
    let mut walls = Vec::new();
    for (i, (ws, w)) in case.walls.iter().zip(sim.walls()).enumerate() {
        let velocity = Vec3::from(ws.velocity);
        let mat = nmat + i;
        // its motions from the start of each phase: velocity, oscillation [amplitude, 2 pi f],
        // rotation [unit axis, point, rate]; and the axis of its axis torque (as Simulation's walls)
        let v3 = |a: [f64; 3]| json!(a);
        let motions: Vec<Value> = super::wall_motions(case, &ws.name)
            .iter()
            .map(|m| {
                json!({
                    "phase": m.phase,
                    "velocity": v3(m.velocity),
                    "osc": m.oscillation.map(|o| json!([o.amplitude, 2.0 * std::f64::consts::PI * o.frequency])),
                    "rot": m.rotation.map(|r| {
                        let a = Vec3::from(r.axis).normalize();
                        json!([[a.x, a.y, a.z], r.point, r.angular_velocity])
                    }),
                })
            })
            .collect();
        let axis = w.rotation.as_ref().map(|r| json!([[r.point.x, r.point.y, r.point.z], [r.axis.x, r.axis.y, r.axis.z]]));
        let mut j = json!({
            "name": ws.name,
            "material": mat,
            "velocity": [velocity.x, velocity.y, velocity.z],
            "remove_at": ws.remove_at,
            "motions": motions,
            "torque_axis": axis,
            "servo": w.servo.as_ref().map(|sv| json!({
                "direction": [sv.direction.x, sv.direction.y, sv.direction.z],
                "target": sv.target, "gain": sv.gain, "max_speed": sv.max_speed,
            })),
        });
        match (&ws.shape, &w.shape) {
            (_, Shape::Plane(pl)) => {
                let n = pl.normal;
                let axis = (0..3).find(|&k| (n[k].abs() - 1.0).abs() < 1e-15 && (0..3).all(|q| q == k || n[q] == 0.0));
                match axis {
                    Some(axis) => {
                        j["kind"] = json!("wall");
                        j["axis"] = json!(axis);
                        j["at"] = json!(pl.point[axis]);
                    }
                    None => {
                        // one triangle in the plane whose incircle holds every contact: no edges touched
                        let centre = 0.5 * (lo + hi);
                        let c = centre - n * (centre - pl.point).dot(&n);
                        let rho = (hi - lo).norm() + velocity.norm() * duration;
                        let a = if n.x.abs() < 0.9 { Vec3::x() } else { Vec3::y() };
                        let u = n.cross(&a).normalize();
                        let v = n.cross(&u);
                        let verts: Vec<Value> = [90.0f64, 210.0, 330.0]
                            .iter()
                            .map(|deg| {
                                let t = deg.to_radians();
                                let x = c + (u * t.cos() + v * t.sin()) * (2.0 * rho);
                                json!([x.x, x.y, x.z])
                            })
                            .collect();
                        j["kind"] = json!("facet");
                        j["vertices"] = json!(verts);
                        notes.push(format!("wall {}: the plane is one YADE facet, a triangle whose incircle (radius {rho:.3} m) covers the domain", ws.name));
                    }
                }
            }
            (_, Shape::Mesh(m)) => {
                let f = out.join("meshes").join(format!("{}.stl", ws.name));
                std::fs::create_dir_all(out.join("meshes")).map_err(|e| io(&f, e))?;
                m.write_stl(&f).map_err(|e| io(&f, e))?;
                files.push(f);
                j["kind"] = json!("stl");
                j["file"] = json!(format!("meshes/{}.stl", ws.name));
                notes.push(format!(
                    "wall {}: YADE facets act at mid-overlap and drive shear by the contact point's velocity; a sphere on the shared edge of two coplanar facets touches both",
                    ws.name
                ));
            }
            (_, Shape::Disc(dc)) => {
                j["kind"] = json!("ball");
                j["center"] = json!([dc.center.x, dc.center.y, dc.center.z]);
                j["radius"] = json!(dc.radius);
                notes.push(format!("wall {}: a fixed YADE sphere (sphere-sphere geometry: mid-overlap contact point, YADE's shear increment)", ws.name));
            }
            (WallShape::Box(b), _) => {
                for &k in &idx {
                    let x = p.pos[k];
                    if !(x.x > b.lo[0] && x.x < b.hi[0] && x.y > b.lo[1] && x.y < b.hi[1]) {
                        return Err(refuse(case, &format!("wall[{i}].box ({})", ws.name), &format!("particle {} starts outside the box; four YADE walls model the box from inside only", p.id[k])));
                    }
                }
                j["kind"] = json!("box");
                j["sides"] = json!([[0, b.lo[0]], [0, b.hi[0]], [1, b.lo[1]], [1, b.hi[1]]]);
            }
            (_, Shape::Segments(_)) => unreachable!("segments refused in check"),
        }
        walls.push(j);
    }

    // materials: talus's in order (particles), then one copy per wall
    let part_mats: Vec<usize> = {
        let mut m: Vec<usize> = idx.iter().map(|&i| p.material[i] as usize).collect();
        // and those of the particles inserted later
        m.extend(inserted.iter().map(|r| r.material as usize));
        m.sort_unstable();
        m.dedup();
        m
    };
    let wall_mat: Vec<usize> =
        case.walls.iter().map(|w| case.material_index(&w.material, "wall.material").map(|k| k as usize)).collect::<Result<_, _>>()?;
    let mut mats: Vec<Value> = case
        .materials
        .iter()
        .map(|m| json!({"name": m.name, "E": m.youngs_modulus, "nu": m.poisson_ratio, "rho": m.density, "mu": m.friction, "viscel": Value::Null}))
        .collect();
    for (i, ws) in case.walls.iter().enumerate() {
        let m = &case.materials[wall_mat[i]];
        mats.push(json!({"name": format!("wall:{}", ws.name), "E": m.youngs_modulus, "nu": m.poisson_ratio, "rho": m.density, "mu": m.friction, "viscel": Value::Null}));
    }
    let mut en = Vec::new();
    if hertz {
        for (ia, &a) in part_mats.iter().enumerate() {
            for &b in &part_mats[ia..] {
                en.push(json!([a, b, mix(&case.materials[a], &case.materials[b], Mixing::Yade).restitution]));
            }
            for (i, &wm) in wall_mat.iter().enumerate() {
                en.push(json!([a, nmat + i, mix(&case.materials[a], &case.materials[wm], Mixing::Yade).restitution]));
            }
        }
        if part_mats.len() > 1 || wall_mat.iter().any(|&w| part_mats.first().is_some_and(|&a| {
            let (x, y) = (&case.materials[a], &case.materials[w]);
            x.youngs_modulus != y.youngs_modulus || x.poisson_ratio != y.poisson_ratio
        })) {
            notes.push("materials differ in E or nu: YADE's Mindlin combines the shear modulus its own way (talus: G* in series)".into());
        }
    } else {
        // ViscElMat constants: one particle material, one radius when derived
        if part_mats.len() > 1 {
            return Err(refuse(case, "particles.material", "hooke: YADE's ViscElMat combines per-material constants; the export handles one particle material"));
        }
        let pm = part_mats.first().copied().unwrap_or(0);
        let law = match (case.contact.stiffness, case.contact.characteristic_velocity) {
            (Some(h), _) => Hooke::Explicit(h),
            (None, Some(v)) => Hooke::Derived { characteristic_velocity: v },
            _ => unreachable!("validated"),
        };
        let (r, m) = match idx.first() {
            Some(&i) => (p.radius[i], p.mass[i]),
            None => (1.0, 1.0),
        };
        if matches!(law, Hooke::Derived { .. }) && idx.iter().any(|&i| p.radius[i] != r || p.mass[i] != m) {
            return Err(refuse(
                case,
                "contact.characteristic_velocity",
                "talus derives hooke constants per pair from R* and m*; YADE's ViscElMat combines per-material constants, which give them back for particles of one radius only: give contact.stiffness",
            ));
        }
        let mp = &case.materials[pm];
        let pp = (idx.len() > 1).then(|| law.coefficients(&mix(mp, mp, Mixing::Yade), PairInertia::particles(r, r, m, m)));
        let pw: Vec<_> = case
            .walls
            .iter()
            .enumerate()
            .map(|(i, ws)| {
                let pi = match &ws.shape {
                    WallShape::Disc(dc) => PairInertia::curved_wall(r, dc.radius, m),
                    _ => PairInertia::wall(r, m),
                };
                law.coefficients(&mix(mp, &case.materials[wall_mat[i]], Mixing::Yade), pi)
            })
            .collect();
        let mut per_mat = [[0.0; 4]; 1];
        let mut per_wall = vec![[0.0; 4]; case.walls.len()];
        for (q, name) in ["kn", "kt", "gamma_n", "gamma_t"].iter().enumerate() {
            let get = |h: &crate::contact::hooke::HookeExplicit| [h.kn, h.kt, h.gamma_n, h.gamma_t][q];
            let (pv, wv) = series_split(pp.as_ref().map(get), &pw.iter().map(get).collect::<Vec<_>>()).map_err(|i| {
                refuse(
                    case,
                    &format!("contact ({name}) against wall {}", case.walls[i].name),
                    &format!(
                        "the wall needs {name} = {:e} against the particles' {:e}: YADE's series combination of per-material constants cannot give it",
                        get(&pw[i]),
                        pp.as_ref().map(get).unwrap_or(0.0)
                    ),
                )
            })?;
            per_mat[0][q] = pv;
            for (i, x) in wv.into_iter().enumerate() {
                per_wall[i][q] = x;
            }
        }
        for (k, mj) in mats.iter_mut().enumerate() {
            let c = if k < nmat { per_mat[0] } else { per_wall[k - nmat] };
            mj["viscel"] = json!(c);
        }
    }

    // probes: the header of Probes::create (a turning wall's axis torque after its other columns)
    let mut header = String::from("time_s,step,phase,kinetic_energy_j,contacts");
    let inserting = case.phases.iter().any(|p| !p.inserts.is_empty());
    if inserting {
        header.push_str(",particles");
    }
    for (ws, w) in case.walls.iter().zip(sim.walls()) {
        for c in ["x", "y", "z"] {
            let _ = write!(header, ",{}_force_{c}_n", ws.name);
        }
        for c in ["x", "y", "z"] {
            let _ = write!(header, ",{}_torque_{c}_n_m", ws.name);
        }
        if w.rotation.is_some() {
            let _ = write!(header, ",{}_axis_torque_n_m", ws.name);
        }
        if w.servo.is_some() {
            let _ = write!(header, ",{}_travel_m", ws.name);
        }
    }
    if case.output.mass_below_z.is_some() {
        header.push_str(",mass_below_kg");
    }
    if case.output.momentum {
        header.push_str(",momentum_x_kg_m_s,momentum_y_kg_m_s,momentum_z_kg_m_s");
    }
    for id in &case.output.track {
        if !idx.iter().any(|&i| p.id[i] == *id) {
            return Err(TalusError::Input(format!("{}: output.track: no particle with id {id}", case.path.display())));
        }
        for q in ["x_m", "y_m", "z_m", "vx_m_s", "vy_m_s", "vz_m_s", "wx_rad_s", "wy_rad_s", "wz_rad_s", "fx_n", "fy_n", "fz_n"] {
            let _ = write!(header, ",p{id}_{q}");
        }
    }
    let phases: Vec<Value> = case
        .phases
        .iter()
        .map(|ph| {
            let remove: Vec<usize> = ph.remove_walls_at_end.iter().filter_map(|n| case.walls.iter().position(|w| &w.name == n)).collect();
            json!({"name": ph.name, "duration": ph.duration, "frac": ph.kinetic_energy_fraction, "settle": ph.settle_extra, "remove": remove})
        })
        .collect();
    match case.contact.wall_contact_point {
        None | Some(WallContactPoint::Surface) => {}
        Some(p @ (WallContactPoint::MidOverlap | WallContactPoint::Radius)) => notes.push(format!(
            "contact.wall_contact_point = \"{}\": YADE's flat walls act on the surface; the probes' torques use the point talus uses",
            p.name()
        )),
    }
    let g = case.simulation.gravity;
    let periodic = [0, 1, 2].map(|k| case.simulation.domain.is_periodic(k));
    let config = json!({
        "dt": dt,
        "skin": skin,
        "dimension": if two_d { 2 } else { 3 },
        "gravity": g,
        "domain": [d.lo, d.hi],
        "model": if hertz { "hertz" } else { "hooke" },
        "wall_arm": opts.wall_arm_overlap,
        "materials": mats,
        "en": en,
        "walls": walls,
        "clumps": clumps,
        "phases": phases,
        "interval": case.output.interval,
        "mass_below_z": case.output.mass_below_z,
        "track": case.output.track,
        "final_state": case.output.final_state,
        // snapshots for continuum fields (python3 -m compare CASE.toml --fields AXIS)
        "snapshot_interval": if case.output.contacts { case.output.snapshot_interval } else { None },
        "momentum": case.output.momentum,
        "periodic": periodic,
        "header": header,
        "particles_column": inserting,
        // the particles a talus run inserted: [step, id, x, y, z, vx, vy, vz, radius, material index, density]
        "inserted": inserted.iter().map(|r| json!([r.step, r.id, r.pos[0], r.pos[1], r.pos[2], r.vel[0], r.vel[1], r.vel[2], r.radius, r.material, case.materials[r.material as usize].density])).collect::<Vec<_>>(),
    });

    let mut s = String::new();
    let _ = writeln!(s, "# {} exported by talus {} for YADE 2023.02a.", case.path.display(), env!("CARGO_PKG_VERSION"));
    let _ = writeln!(s, "# Run it in this folder:  yade -n -j 1 -x talus.py   (one thread: YADE on several is not deterministic)");
    let _ = writeln!(s, "# It writes probes.csv with the columns of talus's probes.csv.");
    for n in &notes {
        let _ = writeln!(s, "# Note: {n}");
    }
    let text = serde_json::to_string_pretty(&config).map_err(|e| TalusError::Run(format!("exporting {}: {e}", case.path.display())))?;
    let _ = writeln!(s, "import json\nC = json.loads(r'''{text}''')\n");
    s.push_str(DRIVER);
    let script = out.join("talus.py");
    std::fs::write(&script, s).map_err(|e| io(&script, e))?;
    Ok(Exported { files, command: format!("cd {} && yade -n -j 1 -x talus.py", out.display()), notes })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_split_gives_back_the_pair_constants() {
        for (pp, pw) in [(Some(397.18), vec![604.2, 397.18 * 2.0, 500.0]), (None, vec![1.0, 0.0]), (Some(0.0), vec![0.0, 3.0])] {
            let (p, w) = series_split(pp, &pw).unwrap();
            if let Some(x) = pp {
                assert!((combine(p, p) - x).abs() <= 1e-15 * x.max(1.0), "{p} {x}");
            }
            for (wi, want) in w.iter().zip(&pw) {
                let got = combine(p, *wi);
                assert!((got - want).abs() <= 1e-14 * want.max(1.0), "{got} {want}");
            }
        }
        // a wall stiffer than twice the particles' pair value cannot be made
        assert_eq!(series_split(Some(1.0), &[2.5]), Err(0));
    }
}
