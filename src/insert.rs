//! Particle insertion (`[[phase.insert]]`, LIGGGHTS's `fix insert/rate/region`):
//! every `interval` seconds from the start of its phase, an insertion places a
//! batch that brings the number (or mass) inserted up to its rate times the
//! time to the end of the batch's interval, until its total is in.
//!
//! A batch is the same on every rank and for any thread count: its random
//! numbers come from ChaCha8 seeded by (seed, batch number), its particles are
//! placed one after another at random points of the region (wholly inside it),
//! each rejected while it overlaps a particle already in the region (gathered
//! from every rank) or one placed before it in the batch, and its ids follow
//! the largest id of the run. Each rank keeps the new particles its box owns;
//! they join at the list rebuild the batch asks for, as migrants do.

use crate::case::{Case, InsertSection, RadiusSection, RegionSection};
use crate::dim::Vec3;
use crate::error::TalusError;
use crate::particles::{ParticleInit, Particles, Record};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Default time between batches (s).
pub const DEFAULT_INTERVAL: f64 = 0.01;
/// Tries to place one particle before the batch is given up.
pub const ATTEMPTS: usize = 2000;

/// One inserted particle as the run logs it: the step at whose start it came
/// in (its time), the particle as inserted, its material index.
#[derive(Clone, Debug, PartialEq)]
pub struct Inserted {
    pub step: u64,
    pub time: f64,
    pub init: ParticleInit,
    pub material: u16,
}

/// What an insertion has done so far (kept in the state and its checkpoints).
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Progress {
    /// Batches placed.
    pub batches: u64,
    /// Particles inserted.
    pub count: u64,
    /// Mass inserted (kg).
    pub mass: f64,
    /// No more to insert (the total is in).
    pub done: bool,
}

/// Every insertion's progress, by phase then by insertion, and the next free id.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct Insertions {
    pub progress: Vec<Vec<Progress>>,
    pub next_id: u64,
}

impl Insertions {
    pub fn new(case: &Case, next_id: u64) -> Self {
        Insertions { progress: case.phases.iter().map(|p| vec![Progress::default(); p.inserts.len()]).collect(), next_id }
    }

    /// Particles inserted in all (every rank's).
    pub fn inserted(&self) -> u64 {
        self.progress.iter().flatten().map(|p| p.count).sum()
    }
}

/// The region's box (lo, hi).
pub fn region_box(r: &RegionSection) -> (Vec3, Vec3) {
    match *r {
        RegionSection::Box { lo, hi } => (Vec3::from(lo), Vec3::from(hi)),
        RegionSection::Cylinder { center, radius, lo, hi } => {
            (Vec3::new(center[0] - radius, center[1] - radius, lo), Vec3::new(center[0] + radius, center[1] + radius, hi))
        }
    }
}

/// Largest radius an insertion draws.
pub fn max_radius(r: &RadiusSection) -> f64 {
    match r {
        RadiusSection::Uniform { max, .. } => *max,
        RadiusSection::Discrete { values, .. } => values.iter().cloned().fold(0.0, f64::max),
    }
}

/// Smallest radius an insertion draws.
pub fn min_radius(r: &RadiusSection) -> f64 {
    match r {
        RadiusSection::Uniform { min, .. } => *min,
        RadiusSection::Discrete { values, .. } => values.iter().cloned().fold(f64::INFINITY, f64::min),
    }
}

/// When batch `k` of an insertion is placed, from its phase's start (s).
pub fn batch_time(ins: &InsertSection, k: u64) -> f64 {
    k as f64 * ins.interval.unwrap_or(DEFAULT_INTERVAL)
}

/// A radius drawn from the insertion's distribution.
fn draw_radius(r: &RadiusSection, rng: &mut ChaCha8Rng) -> f64 {
    match r {
        RadiusSection::Uniform { min, max } => min + (max - min) * rng.random::<f64>(),
        RadiusSection::Discrete { values, weights } => {
            let total: f64 = weights.iter().sum();
            let mut u = rng.random::<f64>() * total;
            for (v, w) in values.iter().zip(weights) {
                if u < *w {
                    return *v;
                }
                u -= w;
            }
            *values.last().unwrap_or(&0.0)
        }
    }
}

/// A random centre for a particle of radius r wholly inside the region.
fn draw_centre(region: &RegionSection, r: f64, rng: &mut ChaCha8Rng) -> Vec3 {
    let mut u = |a: f64, b: f64| a + (b - a) * rng.random::<f64>();
    match *region {
        RegionSection::Box { lo, hi } => Vec3::new(u(lo[0] + r, hi[0] - r), u(lo[1] + r, hi[1] - r), u(lo[2] + r, hi[2] - r)),
        RegionSection::Cylinder { center, radius, lo, hi } => {
            let rr = radius - r;
            loop {
                let (x, y) = (u(-rr, rr), u(-rr, rr));
                if x * x + y * y <= rr * rr {
                    return Vec3::new(center[0] + x, center[1] + y, u(lo + r, hi - r));
                }
            }
        }
    }
}

/// The particles to place in the next batch of insertion `ins` (its progress
/// `pr`), with `existing` the (centre, radius) of every particle that may reach
/// into the region (from every rank). Returns the new particles (ids from
/// `next_id` on) and updates `pr` and `next_id`; an error names the insertion
/// (`at`) when a particle cannot be placed.
pub fn place_batch(
    case: &Case,
    at: &str,
    ins: &InsertSection,
    pr: &mut Progress,
    next_id: &mut u64,
    existing: &[(Vec3, f64)],
) -> Result<Vec<ParticleInit>, TalusError> {
    let interval = ins.interval.unwrap_or(DEFAULT_INTERVAL);
    let end = (pr.batches + 1) as f64 * interval;
    let density = case.materials.iter().find(|m| m.name == ins.material).map(|m| m.density).unwrap_or(1.0);
    let mass_of = |r: f64| density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
    // particles inserted by the end of this batch's interval, and the total
    let (target_n, target_m) = match (ins.count, ins.rate, ins.mass, ins.mass_rate) {
        (Some(n), Some(rate), _, _) => (((rate * end + 1e-9).floor() as u64).min(n), f64::INFINITY),
        (_, _, Some(m), Some(rate)) => (u64::MAX, (rate * end).min(m)),
        _ => (0, 0.0),
    };
    let mut rng = ChaCha8Rng::seed_from_u64(ins.seed ^ pr.batches.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut placed: Vec<ParticleInit> = Vec::new();
    let vel = Vec3::from(ins.velocity);
    // squared distance between centres, across periodic faces the nearest image's
    let period = case.simulation.domain.period();
    let dist2 = |a: &Vec3, b: &Vec3| {
        let mut d = a - b;
        for k in 0..3 {
            if period[k] > 0.0 {
                d[k] -= period[k] * (d[k] / period[k]).round();
            }
        }
        d.norm_squared()
    };
    loop {
        if pr.count >= target_n {
            break;
        }
        let r = draw_radius(&ins.radius, &mut rng);
        if ins.mass.is_some() && pr.mass + mass_of(r) > target_m {
            break;
        }
        let mut found = None;
        for _ in 0..ATTEMPTS {
            let c = draw_centre(&ins.region, r, &mut rng);
            let free = existing.iter().all(|(x, rx)| dist2(x, &c) >= (rx + r) * (rx + r))
                && placed.iter().all(|q| dist2(&q.pos, &c) >= (q.radius + r) * (q.radius + r));
            if free {
                found = Some(c);
                break;
            }
        }
        let Some(c) = found else {
            return Err(TalusError::Run(format!(
                "{at}: batch {} (at {:.6} s into the phase) could place only {} particles: the next one (radius {r} m) found no free place in the region after {ATTEMPTS} tries; enlarge the region, or lower the rate or the interval",
                pr.batches,
                batch_time(ins, pr.batches),
                placed.len()
            )));
        };
        placed.push(ParticleInit { id: *next_id, pos: c, vel, omega: Vec3::zeros(), radius: r });
        *next_id += 1;
        pr.count += 1;
        pr.mass += mass_of(r);
    }
    pr.batches += 1;
    let total_reached = match (ins.count, ins.mass) {
        (Some(n), _) => pr.count >= n,
        (_, Some(m)) => {
            // the next particle would overshoot the total: the smallest one decides
            pr.mass + mass_of(min_radius(&ins.radius)) > m
        }
        _ => true,
    };
    pr.done = total_reached;
    Ok(placed)
}

/// The new particles as records (all owned). A particle is inserted at the
/// start of a step (at its place, at the insertion's velocity, as LIGGGHTS
/// creates one between runs) but joins the arrays at the list rebuild inside
/// the step, after the first half kick and the drift: so it joins where those
/// would have taken it under its weight alone (v + g dt/2, x + (v + g dt/2) dt),
/// with force m g.
/// (`mid_step` false: they join before the step starts, as at the start of a
/// run, where they are.)
pub fn records(inits: &[ParticleInit], density: f64, material: u16, gravity: Vec3, dt: f64, mid_step: bool) -> Vec<Record> {
    let mut q = Particles::default();
    for p in inits {
        q.push_sphere(p, density, material);
    }
    (0..q.len())
        .map(|i| {
            let mut r = q.record(i);
            if mid_step {
                r.vel += gravity * (0.5 * dt);
                r.pos += r.vel * dt;
            }
            r.force = gravity * r.mass;
            r
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(radius: RadiusSection, region: RegionSection) -> (Case, InsertSection) {
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/cases/pour.toml")).unwrap();
        let case = Case::parse(&text, std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/cases/pour.toml"))).unwrap();
        let mut ins = case.phases[0].inserts[0].clone();
        ins.radius = radius;
        ins.region = region;
        ins.count = Some(100_000);
        ins.rate = Some(1.0e5);
        (case, ins)
    }

    #[test]
    fn a_batch_lies_inside_its_region_and_overlaps_nothing() {
        let region = RegionSection::Cylinder { center: [0.01, -0.02], radius: 0.02, lo: 0.03, hi: 0.08 };
        let (case, ins) = case(RadiusSection::Uniform { min: 0.0014, max: 0.0016 }, region.clone());
        // spheres already there, on the axis
        let existing: Vec<(Vec3, f64)> = (0..20).map(|k| (Vec3::new(0.01, -0.02, 0.032 + 0.0025 * k as f64), 0.0012)).collect();
        let (mut pr, mut next) = (Progress::default(), 1000);
        let got = place_batch(&case, "test", &ins, &mut pr, &mut next, &existing).unwrap();
        assert_eq!(got.len(), 1000, "rate 1e5/s over 10 ms");
        assert_eq!((pr.count, pr.batches, next), (1000, 1, 2000));
        assert_eq!(got.iter().map(|p| p.id).collect::<Vec<_>>(), (1000..2000).collect::<Vec<_>>());
        for (k, p) in got.iter().enumerate() {
            assert!((0.0014..=0.0016).contains(&p.radius));
            let (dx, dy) = (p.pos.x - 0.01, p.pos.y + 0.02);
            assert!((dx * dx + dy * dy).sqrt() + p.radius <= 0.02 + 1e-12 && p.pos.z - p.radius >= 0.03 && p.pos.z + p.radius <= 0.08);
            for (x, r) in &existing {
                assert!((p.pos - x).norm() >= p.radius + r);
            }
            for q in &got[..k] {
                assert!((p.pos - q.pos).norm() >= p.radius + q.radius);
            }
        }
        // the same seed and batch give the same particles; the next batch others
        let (mut pr2, mut next2) = (Progress::default(), 1000);
        assert_eq!(place_batch(&case, "test", &ins, &mut pr2, &mut next2, &existing).unwrap(), got);
        let again = place_batch(&case, "test", &ins, &mut pr2, &mut next2, &existing).unwrap();
        assert_ne!(again[0].pos, got[0].pos);
    }

    #[test]
    fn discrete_radii_come_in_the_weights_given() {
        let region = RegionSection::Box { lo: [-0.09, -0.09, 0.0], hi: [0.09, 0.09, 0.14] };
        let (case, ins) = case(RadiusSection::Discrete { values: vec![0.001, 0.002], weights: vec![3.0, 1.0] }, region);
        let (mut pr, mut next) = (Progress::default(), 1);
        let got = place_batch(&case, "test", &ins, &mut pr, &mut next, &[]).unwrap();
        let small = got.iter().filter(|p| p.radius == 0.001).count() as f64 / got.len() as f64;
        assert!(got.iter().all(|p| p.radius == 0.001 || p.radius == 0.002));
        assert!((small - 0.75).abs() < 0.04, "{small}");
    }

    #[test]
    fn a_mass_rate_brings_the_mass_in_up_to_its_total() {
        let region = RegionSection::Box { lo: [-0.09, -0.09, 0.0], hi: [0.09, 0.09, 0.14] };
        let (case, mut ins) = case(RadiusSection::Uniform { min: 0.0014, max: 0.0016 }, region);
        (ins.count, ins.rate, ins.mass, ins.mass_rate) = (None, None, Some(0.01), Some(0.2));
        let m_max = 2500.0 * 4.0 / 3.0 * std::f64::consts::PI * 0.0016f64.powi(3);
        let (mut pr, mut next) = (Progress::default(), 1);
        let mut k = 0;
        while !pr.done {
            place_batch(&case, "test", &ins, &mut pr, &mut next, &[]).unwrap();
            k += 1;
            // 0.2 kg/s up to the end of each 10 ms batch, capped at the total 0.01 kg
            let target = (0.2 * 0.01 * k as f64).min(0.01);
            assert!(pr.mass <= target + 1e-15 && pr.mass > target - m_max, "batch {k}: {} kg, target {target}", pr.mass);
            assert!(k < 10);
        }
        assert_eq!(k, 5);
    }
}
