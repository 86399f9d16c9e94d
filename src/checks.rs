//! Set-up checks that need more than the case file: the machine's memory
//! against the particle count (before anything is allocated), particles
//! against the walls they start next to, and the time step against the
//! stiffest contact of the case. `Simulation::new_on` calls them; every message
//! names the file, the key or particle, and the value.

use crate::case::{Case, ModelName, ParticleSource};
use crate::error::TalusError;
use crate::parallel::comm::Comm;
use crate::particles::Particles;
use crate::walls::{Shape, Wall};

/// Memory one particle may need (bytes), a generous estimate from the data
/// structures: the input record (88 B); the particle arrays (15 fields, about
/// 210 B) and as much again for ghost copies; the neighbour list (about 10
/// candidate pairs of 8 B with 24 B of history and 24 B of pair inertia: 560 B)
/// and wall candidates; the contact history keyed by ids (about 6 contacts of
/// 40 B); Gear derivatives (200 B); the gathered records and their bytes when
/// rank 0 writes a checkpoint or snapshot (about 400 B). That is about 1.9 kB,
/// rounded up.
pub const BYTES_PER_PARTICLE: f64 = 2048.0;

/// Memory this machine can give (bytes) and where the figure comes from:
/// `MemAvailable` in /proc/meminfo, else `MemTotal`; None when neither can be read.
pub fn available_memory() -> Option<(f64, &'static str)> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let field = |key: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(key))
            .and_then(|rest| rest.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
            .map(|kb| kb * 1024.0)
    };
    field("MemAvailable:")
        .map(|b| (b, "MemAvailable in /proc/meminfo"))
        .or_else(|| field("MemTotal:").map(|b| (b, "MemTotal in /proc/meminfo")))
}

/// MPI ranks on this machine (every rank holds the whole particle set while a
/// run starts): OpenMPI's and MPICH's local size, else 1.
fn ranks_on_this_machine() -> f64 {
    ["OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS"]
        .iter()
        .find_map(|k| std::env::var(k).ok()?.parse::<f64>().ok())
        .unwrap_or(1.0)
        .max(1.0)
}

/// Refuse `count` particles whose memory would exceed the machine's, before
/// they are allocated; the key and value are the input that set the count. A
/// collective: every rank decides on the tightest machine's figures, so every
/// rank gives the same answer.
pub fn memory(case: &Case, count: usize, comm: &Comm) -> Result<(), TalusError> {
    let ranks = ranks_on_this_machine();
    let need = count as f64 * BYTES_PER_PARTICLE * ranks;
    let (avail, source) = available_memory().unwrap_or((f64::INFINITY, "unknown"));
    let mine: Vec<u8> = [need, avail, ranks].iter().flat_map(|x| x.to_le_bytes()).collect();
    let all = comm.all_gather_bytes(&mine);
    let figures = |b: &Vec<u8>| -> [f64; 3] { [0, 1, 2].map(|k| f64::from_le_bytes(b[8 * k..8 * k + 8].try_into().unwrap())) };
    let (rank, [need, avail, ranks]) = all
        .iter()
        .map(figures)
        .enumerate()
        .max_by(|a, b| (a.1[0] / a.1[1]).total_cmp(&(b.1[0] / b.1[1])))
        .expect("at least one rank");
    if need <= avail {
        return Ok(());
    }
    let ps = &case.particles;
    let (key, value) = match &ps.source {
        ParticleSource::Lattice(l) => ("particles.lattice.count".to_string(), l.count.to_string()),
        ParticleSource::Csv(f) => ("particles.csv".to_string(), format!("\"{}\"", f.display())),
        ParticleSource::List(_) => ("particles.list".to_string(), format!("[{count} entries]")),
    };
    let shared = if ranks > 1.0 { format!(" x {ranks} MPI ranks on one machine, each holding every particle while the run starts") } else { String::new() };
    let source = if comm.size() > 1 && rank != comm.rank() { format!("{source}, rank {rank}") } else { source.to_string() };
    Err(TalusError::Input(format!(
        "{}: {key} = {value}: {count} particles need about {need:.3e} bytes of memory ({BYTES_PER_PARTICLE} bytes per particle, a generous estimate{shared}), more than the {avail:.3e} bytes available ({source})",
        case.path.display()
    )))
}

/// Refuse a particle whose centre starts behind a plane wall (planes are
/// one-sided: particles live on the side the normal points to), or that starts
/// overlapping a wall by more than `particles.overlap_tolerance` of its radius.
pub fn wall_overlaps(case: &Case, p: &Particles, walls: &[Wall]) -> Result<(), TalusError> {
    let path = case.path.display();
    let tol = case.particles.overlap_tolerance;
    let mut feats = Vec::new();
    for i in 0..p.len() {
        let (c, r) = (p.pos[i], p.radius[i]);
        for w in walls {
            if let Shape::Plane(pl) = &w.shape {
                let d = pl.distance(&c);
                if d <= 0.0 {
                    return Err(TalusError::Input(format!(
                        "{path}: particle id {} at {:?} is behind the plane wall \"{}\" (signed distance {d:.4e} m; planes are one-sided: particles live on the side the normal {:?} points to)",
                        p.id[i],
                        c.as_slice(),
                        w.name,
                        pl.normal.as_slice()
                    )));
                }
            }
            feats.clear();
            w.candidates(&c, r, 0.0, &mut feats);
            let hit = |f: u32| if p.ellipse[i] { w.ellipse_contact(f, &p.ellipse_of(i)) } else { w.contact(f, &c, r) };
            let ov = feats.iter().filter_map(|&f| hit(f)).map(|h| h.overlap).fold(0.0, f64::max);
            if ov > tol * r {
                return Err(TalusError::Input(format!(
                    "{path}: particle id {} overlaps wall \"{}\" by {ov:.4e} m initially, more than particles.overlap_tolerance = {tol} of its radius {r:.4e} m",
                    p.id[i], w.name
                )));
            }
        }
    }
    Ok(())
}

/// Explicit Hooke stiffness: the shortest contact, a half period
/// pi sqrt(m*/k_n) with m* of the two lightest particles (m1 m2 / (m1 + m2),
/// m/2 for equal ones) or of the lightest particle on a wall (m), must span at
/// least 20 time steps unless `simulation.force_timestep` is set. (Hertz and
/// derived Hooke stiffnesses come from the material, which the Rayleigh-time
/// check covers.)
pub fn contact_period(case: &Case, p: &Particles, dt: f64) -> Result<(), TalusError> {
    // the stiffest explicit Hooke law of the case's (the section's or a pair's)
    let stiffest = case
        .contact
        .laws()
        .filter_map(|c| match (c.model, c.stiffness) {
            (ModelName::Hooke, Some(h)) => Some(h),
            (ModelName::Hooke | ModelName::Hertz | ModelName::Dmt | ModelName::Jkr, _) => None,
        })
        .max_by(|a, b| a.kn.total_cmp(&b.kn));
    let Some(h) = stiffest else { return Ok(()) };
    if case.simulation.force_timestep {
        return Ok(());
    }
    let (mut m1, mut m2) = (f64::INFINITY, f64::INFINITY);
    for &m in &p.mass {
        if m < m1 {
            (m1, m2) = (m, m1);
        } else if m < m2 {
            m2 = m;
        }
    }
    let pair = (m2.is_finite()).then(|| (m1 * m2 / (m1 + m2), "the two lightest particles, m1 m2 / (m1 + m2)"));
    let wall = (!case.walls.is_empty() && m1.is_finite()).then_some((m1, "the lightest particle on a wall"));
    let Some((m_eff, which)) = [pair, wall].into_iter().flatten().min_by(|a, b| a.0.total_cmp(&b.0)) else { return Ok(()) };
    let period = std::f64::consts::PI * (m_eff / h.kn).sqrt();
    if period < 20.0 * dt {
        return Err(TalusError::Input(format!(
            "{}: contact.stiffness.kn = {}: the shortest contact lasts pi sqrt(m*/kn) = {period:.4e} s (m* = {m_eff:.4e} kg, {which}), {:.2} time steps of {dt:.4e} s; at least 20 are needed (lower simulation.timestep or kn, or set simulation.force_timestep = true to run anyway)",
            case.path.display(),
            h.kn,
            period / dt
        )));
    }
    Ok(())
}
