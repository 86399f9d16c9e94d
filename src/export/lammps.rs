//! A case as a LAMMPS 29Sep2021 deck (`in.talus`, `pair_style granular`),
//! with its particle data file, writing `probes.csv` with talus's columns.
//!
//! The deck is in LAMMPS's conventions (talus with `contact.convention =
//! "lammps"` runs the same equations, [`crate::contact::conventions`]):
//! `hertz/material`, `dmt` or `jkr` with `damping tsuji` and `tangential
//! mindlin` (8 G* a), or `hooke` with `damping velocity` and `tangential
//! linear_history` for explicit Hooke coefficients; every pair of atom types
//! gets its own `pair_coeff` (LAMMPS's automatic mixing of unlike types
//! gives a Hooke force), its E*, G*, restitution and friction mixed as talus
//! mixes them. What the deck works around in this LAMMPS (measured with the
//! Debian binary, docs/cohesion-in-the-reference-codes.md):
//!
//! - `fix wall/gran granular` computes its E* as E / (2 (1 - nu)) and its
//!   `mindlin NULL` stiffness with a misplaced bracket: the deck gives each
//!   wall the modulus that yields talus's mixed E* under that formula, and
//!   the tangential stiffness 8 G* explicitly; one wall fix per wall and
//!   particle material;
//! - the wall fix re-converts its `tsuji` coefficient at each set-up: the
//!   deck sets up once (`run 0`), and every later run is `pre no`;
//! - the wall's torque arm is the full radius (talus's `wall_contact_point =
//!   "radius"` in this convention).
//!
//! Scope: spheres in 3D, planes normal to x, y or z that stay still,
//! phases of fixed duration. Everything else is refused, naming the key.

use super::{phase_steps, refuse, Exported};
use crate::case::{Case, ModelName, RollingModel, WallContactPoint, WallShape};
use crate::contact::hertz::HertzDamping;
use crate::contact::{Convention, EndOfContact, FrictionCap, ShearKinematics, TangentialHistory};
use crate::dim::{Dimension, Vec3};
use crate::error::TalusError;
use crate::integrate::IntegratorKind;
use crate::material::{mix, Mixing, PairMaterial};
use crate::sim::Simulation;
use std::fmt::Write as _;
use std::path::Path;

/// The normal law as LAMMPS writes it.
#[derive(Clone, Copy, Debug)]
enum Law {
    /// `hertz/material`.
    Hertz,
    /// `dmt` with this surface energy (J/m^2).
    Dmt(f64),
    /// `jkr` with this surface energy (J/m^2).
    Jkr(f64),
    /// `hooke kn eta_n` (`damping velocity`), `linear_history kt x_gt mu`.
    Hooke(crate::contact::hooke::HookeExplicit),
}

fn g(x: f64) -> String {
    // 17 significant digits: every f64 reaches LAMMPS as it is
    format!("{x:.16e}")
}

fn io(path: &Path, e: std::io::Error) -> TalusError {
    TalusError::io(format!("writing {}", path.display()), e)
}

/// The law of one section (the case's, or a pair's as `ContactSection::for_pair`
/// makes it) as LAMMPS writes it, or refused naming the key under `at`.
fn law_of(case: &Case, c: &crate::case::ContactSection, at: &str) -> Result<Law, TalusError> {
    let law = match c.model {
        ModelName::Hertz => Law::Hertz,
        ModelName::Dmt => Law::Dmt(c.surface_energy.unwrap_or(0.0)),
        ModelName::Jkr => Law::Jkr(c.surface_energy.unwrap_or(0.0)),
        ModelName::Hooke => match c.stiffness {
            Some(k) => Law::Hooke(k),
            None => {
                return Err(refuse(
                    case,
                    &format!("{at}.characteristic_velocity"),
                    "LAMMPS takes a Hooke stiffness per pair of atom types, while LIGGGHTS's derived stiffness depends on each pair's R* and m*; give contact.stiffness",
                ))
            }
        },
    };
    if let Law::Hooke(k) = law {
        if k.gamma_n == 0.0 && k.gamma_t != 0.0 {
            return Err(refuse(case, &format!("{at}.stiffness.gamma_t"), "LAMMPS's tangential damping is a multiple of the normal one, which is 0 here"));
        }
    }
    match (law, c.damping) {
        (_, None) | (Law::Hertz | Law::Dmt(_) | Law::Jkr(_), Some(HertzDamping::Tsuji)) => {}
        (_, Some(d)) => {
            return Err(refuse(case, &format!("{at}.damping = \"{}\"", d.name()), "the deck maps restitution to damping as LAMMPS's `damping tsuji` does"));
        }
    }
    Ok(law)
}

/// Refuse what the LAMMPS deck cannot hold, naming the key (every model and
/// option decided here: a new one does not compile until it is).
fn check(case: &Case) -> Result<(), TalusError> {
    let s = &case.simulation;
    if s.dimension == Dimension::Two {
        return Err(refuse(case, "simulation.dimension = 2", "the LAMMPS export writes 3D spheres only"));
    }
    if s.integrator == IntegratorKind::Gear {
        return Err(refuse(case, "simulation.integrator = \"gear\"", "the deck integrates with velocity Verlet (fix nve/sphere)"));
    }
    if !case.particles.ellipses.is_empty() {
        return Err(refuse(case, "particles.ellipses", "LAMMPS's granular pair styles act between spheres"));
    }
    if !case.particles.clumps.is_empty() {
        return Err(refuse(case, "particles.clumps", "the LAMMPS export writes no rigid clumps"));
    }
    let c = &case.contact;
    for (k, l) in c.laws().enumerate() {
        let at = if k == 0 { "contact".to_string() } else { format!("contact.pair[{}]", k - 1) };
        law_of(case, &l, &at)?;
        if let Some(coh) = &l.cohesion {
            return Err(refuse(
                case,
                &format!("{at}.cohesion.model = \"{}\"", coh.model.name()),
                "LAMMPS has no simplified-JKR cohesion (a force proportional to the overlap's area); its adhesive laws are model = \"dmt\" and \"jkr\"",
            ));
        }
    }
    match c.end_of_contact {
        None | Some(EndOfContact::Tensile) => {}
        Some(EndOfContact::Clip) => {
            return Err(refuse(case, "contact.end_of_contact = \"clip\"", "LAMMPS's granular normal force is not clipped (limit_damping is not exported)"));
        }
    }
    match c.tangential {
        None | Some(TangentialHistory::Rescaled) => {}
        Some(t @ (TangentialHistory::Total | TangentialHistory::Incremental)) => {
            return Err(refuse(case, &format!("contact.tangential = \"{}\"", t.name()), "LAMMPS keeps the shear displacement, turned and rescaled to its length (\"rescaled\")"));
        }
    }
    match c.shear_kinematics {
        None | Some(ShearKinematics::Radii) => {}
        Some(k @ (ShearKinematics::ContactPoint | ShearKinematics::FullRadii)) => {
            return Err(refuse(case, &format!("contact.shear_kinematics = \"{}\"", k.name()), "LAMMPS drives the shear spring with the full radii as spin arms (\"radii\")"));
        }
    }
    match c.friction_cap {
        None | Some(FrictionCap::Pulloff) => {}
        Some(f @ (FrictionCap::Total | FrictionCap::Elastic)) => {
            return Err(refuse(case, &format!("contact.friction_cap = \"{}\"", f.name()), "LAMMPS caps friction with |F_el + 2 F_pulloff| for dmt and jkr, the total normal force otherwise (\"pulloff\")"));
        }
    }
    match c.wall_contact_point {
        None | Some(WallContactPoint::Radius) => {}
        Some(p @ (WallContactPoint::MidOverlap | WallContactPoint::Surface)) => {
            return Err(refuse(case, &format!("contact.wall_contact_point = \"{}\"", p.name()), "LAMMPS's wall torque arm is the particle's radius (\"radius\")"));
        }
    }
    match c.rolling {
        None => {}
        Some(r @ (RollingModel::Cdt | RollingModel::Epsd2)) => {
            let name = if r == RollingModel::Cdt { "cdt" } else { "epsd2" };
            return Err(refuse(case, &format!("contact.rolling = \"{name}\""), "LAMMPS 29Sep2021's rolling resistance is its `rolling sds` spring-dashpot-slider, not LIGGGHTS's cdt or epsd2"));
        }
    }
    // (the particles' materials: the initial ones'; the export inserts none)
    for w in &case.walls {
        for m in [&case.particles.material] {
            if c.for_materials(&w.material, m).model == ModelName::Jkr {
                return Err(refuse(
                    case,
                    &format!("wall.{} with a jkr law (particles of material {m})", w.name),
                    "LAMMPS 29Sep2021's `fix wall/gran granular jkr` keeps a wall contact far beyond its pull-off distance and returns NaN forces there (measured with the Debian binary)",
                ));
            }
        }
    }
    for w in &case.walls {
        if w.servo.is_some() {
            return Err(refuse(case, &format!("wall.{}.servo", w.name), "the LAMMPS export writes still walls only"));
        }
        if w.remove_at.is_some() {
            return Err(refuse(case, &format!("wall.{}.remove_at", w.name), "the LAMMPS export writes walls that stay"));
        }
        for m in super::wall_motions(case, &w.name) {
            if !m.is_still() {
                return Err(refuse(case, &m.key, "the LAMMPS export writes still walls only"));
            }
        }
        match &w.shape {
            WallShape::Plane(pl) => {
                let n = pl.normal;
                let aligned = (0..3).any(|k| (n[k].abs() - 1.0).abs() < 1e-15 && (0..3).all(|j| j == k || n[j] == 0.0));
                if !aligned {
                    return Err(refuse(case, &format!("wall.{}.plane.normal", w.name), "the LAMMPS export writes planes normal to x, y or z (fix wall/gran xplane, yplane, zplane)"));
                }
            }
            other => {
                return Err(refuse(case, &format!("wall.{}.{}", w.name, other.key()), "the LAMMPS export writes plane walls only"));
            }
        }
    }
    if case.output.final_state {
        return Err(refuse(case, "output.final_state", "the LAMMPS deck writes probes.csv only, not the final state"));
    }
    for ph in &case.phases {
        if ph.kinetic_energy_fraction.is_some() {
            return Err(refuse(case, &format!("phase.{}.kinetic_energy_fraction", ph.name), "the LAMMPS export writes phases of fixed duration only"));
        }
        if !ph.inserts.is_empty() {
            return Err(refuse(case, &format!("phase.{}.insert", ph.name), "the LAMMPS export inserts no particles"));
        }
        if !ph.remove_walls_at_end.is_empty() {
            return Err(refuse(case, &format!("phase.{}.remove_walls_at_end", ph.name), "the LAMMPS export writes walls that stay"));
        }
    }
    Ok(())
}

/// The words of a `pair_coeff` or a wall fix for the mixed pair `pm`:
/// `wall` writes the wall fix's E so that its formula E / (2 (1 - nu))
/// gives `pm`'s E*, and its tangential stiffness explicitly.
fn model_words(law: Law, pm: &PairMaterial, nu: f64, wall: bool) -> String {
    let e = if wall { 2.0 * pm.y_eff * (1.0 - nu) } else { 2.0 * pm.y_eff * (1.0 - nu * nu) };
    let mu = pm.friction;
    // mindlin's stiffness: 8 G* (times a, by LAMMPS); NULL (8 G* from E, nu) on pairs, explicit on walls
    let kt = if wall { g(8.0 * pm.g_eff) } else { "NULL".to_string() };
    let (normal, tang) = match law {
        Law::Hertz => (format!("hertz/material {} {} {}", g(e), g(pm.restitution), g(nu)), format!("tangential mindlin {kt} 1.0 {}", g(mu))),
        Law::Dmt(gamma) => (format!("dmt {} {} {} {}", g(e), g(pm.restitution), g(nu), g(gamma)), format!("tangential mindlin {kt} 1.0 {}", g(mu))),
        Law::Jkr(gamma) => (format!("jkr {} {} {} {}", g(e), g(pm.restitution), g(nu), g(gamma)), format!("tangential mindlin {kt} 1.0 {}", g(mu))),
        Law::Hooke(k) => {
            let xgt = if k.gamma_n > 0.0 { k.gamma_t / k.gamma_n } else { 0.0 };
            return format!("hooke {} {} tangential linear_history {} {} {} damping velocity", g(k.kn), g(k.gamma_n), g(k.kt), g(xgt), g(mu));
        }
    };
    format!("{normal} {tang} damping tsuji")
}

pub fn export(case: &Case, out: &Path) -> Result<Exported, TalusError> {
    check(case)?;
    // each pair of materials' law (a pair of `[[contact.pair]]`'s, else the section's)
    let law = |a: usize, b: usize| law_of(case, &case.contact.for_materials(&case.materials[a].name, &case.materials[b].name), "contact");
    let sim = Simulation::new(case.clone())?;
    let dt = sim.dt();
    // (a JKR contact beyond touching needs the skin to cover its reach, twice
    // over across LAMMPS's ranks: talus's own skin is at least that already)
    let skin = sim.state().nl.skin;
    let mut notes = Vec::new();
    if case.contact.convention != Convention::Lammps {
        notes.push(format!(
            "the deck runs in LAMMPS's conventions; compare it with talus run with `--set contact.convention=lammps` (the case says {:?})",
            case.contact.convention
        ));
    }
    let nmat = case.materials.len();
    let mixed = |a: usize, b: usize| mix(&case.materials[a], &case.materials[b], Mixing::Liggghts);

    // particles: the data file
    let p = sim.particles();
    let mut idx: Vec<usize> = (0..p.owned()).collect();
    idx.sort_unstable_by_key(|&i| p.id[i]);
    let shift = if idx.first().is_some_and(|&i| p.id[i] == 0) { 1 } else { 0 };
    if shift == 1 {
        notes.push("talus ids start at 0: LAMMPS ids are talus ids + 1 (probe columns keep talus's ids)".into());
    }
    let d = &case.simulation.domain;
    let mut data = String::new();
    let _ = writeln!(data, "LAMMPS data file: the initial particles of {} (exported by talus)\n", case.path.display());
    let _ = writeln!(data, "{} atoms\n{} atom types\n", idx.len(), nmat);
    for k in 0..3 {
        let _ = writeln!(data, "{} {} {}lo {}hi", g(d.lo[k]), g(d.hi[k]), ["x", "y", "z"][k], ["x", "y", "z"][k]);
    }
    data.push_str("\nAtoms # sphere\n\n");
    for &i in &idx {
        let x = p.pos[i];
        let rho = case.materials[p.material[i] as usize].density;
        let _ = writeln!(data, "{} {} {} {} {} {} {}", p.id[i] + shift, p.material[i] + 1, g(2.0 * p.radius[i]), g(rho), g(x.x), g(x.y), g(x.z));
    }
    data.push_str("\nVelocities\n\n");
    for &i in &idx {
        let (v, w) = (p.vel[i], p.omega[i]);
        let _ = writeln!(data, "{} {} {} {} {} {} {}", p.id[i] + shift, g(v.x), g(v.y), g(v.z), g(w.x), g(w.y), g(w.z));
    }
    let data_path = out.join("particles.data");
    std::fs::write(&data_path, data).map_err(|e| io(&data_path, e))?;
    let files = vec![out.join("in.talus"), data_path];

    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(w, "# {} exported by talus {} for LAMMPS 29Sep2021 (pair_style granular).", case.path.display(), env!("CARGO_PKG_VERSION"));
    let _ = writeln!(w, "# Run it in this folder:  lmp -in in.talus -log log.lammps");
    let _ = writeln!(w, "# It writes probes.csv with the columns of talus's probes.csv.");
    let header_at = w.len();
    let b = |k: usize| if case.simulation.domain.is_periodic(k) { "p" } else { "f" };
    let _ = writeln!(w, "\nunits           si\natom_style      sphere\natom_modify     map array\nboundary        {} {} {}", b(0), b(1), b(2));
    let _ = writeln!(w, "newton          off\ncomm_modify     vel yes");
    let _ = writeln!(w, "read_data       particles.data");
    let _ = writeln!(w, "neighbor        {} bin\nneigh_modify    delay 0 every 1 check yes", g(skin));
    let _ = writeln!(w, "group           grains type {}", (1..=nmat).map(|k| k.to_string()).collect::<Vec<_>>().join(" "));
    for k in 0..nmat {
        let _ = writeln!(w, "group           m{} type {}", k + 1, k + 1);
    }

    // every pair of types its own coefficients (LAMMPS's own mixing of unlike types is Hooke's)
    let _ = writeln!(w, "\n# materials: {}", case.materials.iter().map(|m| m.name.as_str()).collect::<Vec<_>>().join(", "));
    let _ = writeln!(w, "pair_style      granular");
    for a in 0..nmat {
        for b in a..nmat {
            let nu = case.materials[a].poisson_ratio;
            let _ = writeln!(w, "pair_coeff      {} {} {}", a + 1, b + 1, model_words(law(a, b)?, &mixed(a, b), nu, false));
        }
    }
    let _ = writeln!(w, "timestep        {}", g(dt));
    let _ = writeln!(w, "fix             integrate grains nve/sphere");
    let gv = Vec3::from(case.simulation.gravity);
    if gv.norm() > 0.0 {
        let u = gv / gv.norm();
        let _ = writeln!(w, "fix             gravi grains gravity {} vector {} {} {}", g(gv.norm()), g(u.x), g(u.y), g(u.z));
    }

    // walls: a fix per wall and particle material (the wall's coefficients are per fix)
    let _ = writeln!(w, "\n# ---- walls: fix wall/gran granular, one per wall and particle material (f_ID[2..4]: the wall's force on a particle)");
    let mut wall_fixes: Vec<(String, Vec<(usize, String)>, usize, f64)> = Vec::new();
    let mut particle_materials: Vec<usize> = idx.iter().map(|&i| p.material[i] as usize).collect();
    particle_materials.sort_unstable();
    particle_materials.dedup();
    for ws in &case.walls {
        let WallShape::Plane(pl) = &ws.shape else {
            return Err(refuse(case, &format!("wall.{}", ws.name), "the LAMMPS export writes plane walls only"));
        };
        let n = Vec3::from(pl.normal);
        let axis = (0..3).find(|&k| n[k].abs() == 1.0).unwrap_or(2);
        let at = pl.point[axis];
        let side = n[axis];
        let wm = case.material_index(&ws.material, "wall.material")? as usize;
        let (lo, hi) = if side > 0.0 { (g(at), "NULL".to_string()) } else { ("NULL".to_string(), g(at)) };
        let mut ids = Vec::new();
        // one fix per material the particles have
        for &k in &particle_materials {
            let id = format!("{}_m{}", ws.name, k + 1);
            let nu = case.materials[k].poisson_ratio;
            let words = model_words(law(k, wm)?, &mixed(k, wm), nu, true);
            let _ = writeln!(w, "fix             {id} m{} wall/gran granular {words} {}plane {lo} {hi} contacts", k + 1, ["x", "y", "z"][axis]);
            ids.push((k, id));
        }
        wall_fixes.push((ws.name.clone(), ids, axis, side));
    }

    // probes
    let _ = writeln!(w, "\n# ---- probes: the columns of talus's probes.csv");
    let _ = writeln!(w, "variable t equal step*{}\nvariable st equal step", g(dt));
    let _ = writeln!(w, "compute ke_t grains ke\ncompute ke_r grains erotate/sphere\nvariable ke equal c_ke_t+c_ke_r");
    let _ = writeln!(w, "compute pa all property/atom omegax omegay omegaz radius");
    let _ = writeln!(w, "compute pc all contact/atom\ncompute pc_sum all reduce sum c_pc\nvariable n_pair equal floor(c_pc_sum/2+0.5)");
    let mut count_terms = vec!["v_n_pair".to_string()];
    for (name, ids, axis, side) in &wall_fixes {
        // the wall's load: minus the sum of its forces on the particles; its torque about the
        // origin from the contact point x - r n (arm r, as talus in LAMMPS's convention)
        let q = ["x", "y", "z"][*axis];
        let mut sums = Vec::new();
        for (k, id) in ids {
            let f = |c: usize| format!("f_{id}[{}]", c + 2);
            let mut c = ["x".to_string(), "y".to_string(), "z".to_string()];
            c[*axis] = format!("({q}-{}*c_pa[4])", g(*side));
            let _ = writeln!(w, "variable {name}_{k}_tx atom -({}*{}-{}*{})", c[1], f(2), c[2], f(1));
            let _ = writeln!(w, "variable {name}_{k}_ty atom -({}*{}-{}*{})", c[2], f(0), c[0], f(2));
            let _ = writeln!(w, "variable {name}_{k}_tz atom -({}*{}-{}*{})", c[0], f(1), c[1], f(0));
            let _ = writeln!(
                w,
                "compute {name}_{k}_sum m{} reduce sum f_{id}[1] {} {} {} v_{name}_{k}_tx v_{name}_{k}_ty v_{name}_{k}_tz",
                k + 1,
                f(0),
                f(1),
                f(2)
            );
            sums.push(format!("{name}_{k}_sum"));
        }
        let total = |col: usize, neg: bool| {
            let s = sums.iter().map(|c| format!("c_{c}[{col}]")).collect::<Vec<_>>().join("+");
            if neg {
                format!("0-({s})")
            } else {
                s
            }
        };
        for (k, c) in ["fx", "fy", "fz"].iter().enumerate() {
            let _ = writeln!(w, "variable {name}_{c} equal {}", total(k + 2, true));
        }
        for (k, c) in ["tx", "ty", "tz"].iter().enumerate() {
            let _ = writeln!(w, "variable {name}_{c} equal {}", total(k + 5, false));
        }
        let _ = writeln!(w, "variable {name}_n equal floor({}+0.5)", total(1, false));
        count_terms.push(format!("v_{name}_n"));
    }
    let _ = writeln!(w, "variable contacts equal {}", count_terms.join("+"));
    let mut header = String::from("time_s,step,phase,kinetic_energy_j,contacts");
    let mut row = String::from("${t},${st},${phase},${ke},${contacts}");
    let mut thermo = String::from("step v_t v_ke v_contacts");
    for (name, ..) in &wall_fixes {
        for c in ["x", "y", "z"] {
            let _ = write!(header, ",{name}_force_{c}_n");
            let _ = write!(row, ",${{{name}_f{c}}}");
            let _ = write!(thermo, " v_{name}_f{c}");
        }
        for c in ["x", "y", "z"] {
            let _ = write!(header, ",{name}_torque_{c}_n_m");
            let _ = write!(row, ",${{{name}_t{c}}}");
            let _ = write!(thermo, " v_{name}_t{c}");
        }
    }
    super::lammps_family_columns(case, w, &mut header, &mut row, &mut thermo);
    for &id in &case.output.track {
        let l = id + shift;
        for (q, v) in [
            ("x_m", "x".to_string()),
            ("y_m", "y".to_string()),
            ("z_m", "z".to_string()),
            ("vx_m_s", "vx".to_string()),
            ("vy_m_s", "vy".to_string()),
            ("vz_m_s", "vz".to_string()),
            ("wx_rad_s", "c_pa".to_string()),
            ("wy_rad_s", "c_pa".to_string()),
            ("wz_rad_s", "c_pa".to_string()),
            ("fx_n", "fx".to_string()),
            ("fy_n", "fy".to_string()),
            ("fz_n", "fz".to_string()),
        ] {
            let value = match q {
                "wx_rad_s" => format!("c_pa[{l}][1]"),
                "wy_rad_s" => format!("c_pa[{l}][2]"),
                "wz_rad_s" => format!("c_pa[{l}][3]"),
                _ => format!("{v}[{l}]"),
            };
            let _ = writeln!(w, "variable p{id}_{q} equal {value}");
            let _ = write!(header, ",p{id}_{q}");
            let _ = write!(row, ",${{p{id}_{q}}}");
            // in the thermo output, so the per-atom computes are current at every probe
            let _ = write!(thermo, " v_p{id}_{q}");
        }
    }
    let every = super::probe_every(case, dt, &mut notes);
    if let (true, Some(iv)) = (case.output.contacts, case.output.snapshot_interval) {
        let reaches = (0..nmat).any(|a| (a..nmat).any(|b| matches!(law(a, b), Ok(Law::Jkr(_)))));
        snapshot_dumps(w, super::steps_every("snapshots", "a snapshot", iv, dt, &mut notes), &wall_fixes, reaches);
    }
    let first = case.phases.first().map(|p| p.name.as_str()).unwrap_or("end");
    let _ = writeln!(w, "variable phase string {first}");
    let _ = writeln!(w, "thermo_style    custom {thermo}\nthermo          {every}\nthermo_modify   lost error norm no");
    let _ = writeln!(w, "\n# step 0: forces at the start (run 0 moves nothing), the first row; the only set-up (the wall fixes convert tsuji's coefficient at each)");
    let _ = writeln!(w, "fix probe all print {every} \"{row}\" append probes.csv screen no");
    let _ = writeln!(w, "run             0 post no");
    let _ = writeln!(w, "print \"{header}\" file probes.csv screen no");
    let _ = writeln!(w, "print \"{row}\" append probes.csv screen no");

    let mut s0 = 0u64;
    for (k, ph) in case.phases.iter().enumerate() {
        let _ = writeln!(w, "\n# ---- phase {k}: {} ({} s)", ph.name, ph.duration);
        let _ = writeln!(w, "variable phase string {}", ph.name);
        let n = phase_steps(s0, ph.duration, dt);
        if n > 0 {
            let _ = writeln!(w, "run             {n} pre no post no");
        }
        s0 += n;
    }
    let _ = writeln!(w, "variable phase string end\nprint \"talus export: done\"");
    let notes_text: String = notes.iter().map(|n| format!("# Note: {n}\n")).collect();
    s.insert_str(header_at, &notes_text);
    let deck = out.join("in.talus");
    std::fs::write(&deck, s).map_err(|e| io(&deck, e))?;
    Ok(Exported { files, command: "lmp -in in.talus -log log.lammps".into(), notes })
}

/// What continuum fields need from the run, at talus's snapshot times
/// (`output.snapshot_interval` with `output.contacts`; `python3 -m compare
/// CASE.toml --fields AXIS` reads them): every particle (id, position,
/// velocity, radius, mass, and each wall fix's contact: flag, force on the
/// particle, contact point) in `particles.<step>.dump`, and every pair in
/// contact in `contacts.<step>.dump` (ids, normal and tangential force on the
/// first, x_first - x_second with the image in contact). See
/// docs/contacts-in-the-reference-codes.md.
fn snapshot_dumps(w: &mut String, every: u64, wall_fixes: &[(String, Vec<(usize, String)>, usize, f64)], reaches: bool) {
    // a law that reaches beyond touching (JKR) keeps contacts apart: the type
    // cutoff lists them, with all-zero rows for the neighbours that do not
    // touch (the reader drops those)
    let cutoff = if reaches { "type" } else { "radius" };
    let _ = writeln!(w, "\n# ---- snapshots for continuum fields (every {every} steps): particles and their wall contacts, pairs in contact");
    let _ = writeln!(w, "compute cpl all pair/local fx fy fz p1 p2 p3 p10 p11 p12 cutoff {cutoff}");
    let _ = writeln!(w, "compute cpi all property/local patom1 patom2 cutoff {cutoff}");
    let _ = writeln!(w, "dump contacts all local {every} contacts.*.dump c_cpi[1] c_cpi[2] c_cpl[*]");
    let mut cols = String::from("id x y z vx vy vz radius mass");
    for (_, ids, ..) in wall_fixes {
        for (_, id) in ids {
            for c in 1..=7 {
                let _ = write!(cols, " f_{id}[{c}]");
            }
        }
    }
    let _ = writeln!(w, "dump particles all custom {every} particles.*.dump {cols}\ndump_modify particles sort id");
    let _ = writeln!(w, "# wall fixes in the particle dump, 7 columns each (in contact, force on the particle, contact point): {}", wall_fixes.iter().flat_map(|(name, ids, ..)| ids.iter().map(move |(_, id)| format!("{id} (wall {name})"))).collect::<Vec<_>>().join(", "));
}
