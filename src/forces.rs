//! The force sweep: gravity, then particle pairs in list order, then walls in
//! wall and feature order. The law is chosen once per sweep (`ContactModel`)
//! and the kernel is monomorphised for it.

use crate::contact::hertz::Hertz;
use crate::contact::ellipse;
use crate::contact::hooke::Hooke;
use crate::contact::{
    evaluate, relative_velocity, torques, yade_shear_velocity, ContactGeom, EndOfContact, NormalLaw, PairInertia,
    ShearKinematics, TangentialOptions,
};
use crate::dim::Vec3;
use crate::fixed::{from_fixed, to_fixed};
use crate::material::PairTable;
use crate::neighbor::NeighborList;
use crate::particles::Particles;
use crate::walls::{carry_history, merge_coincident, Wall, WallHit};

/// The contact law of a run, fixed at set-up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ContactModel {
    Hooke(Hooke),
    Hertz(Hertz),
}

/// Everything the sweep needs besides state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepSettings {
    pub model: ContactModel,
    pub end: EndOfContact,
    pub tang: TangentialOptions,
    pub gravity: Vec3,
    pub dt: f64,
    /// Where a wall contact acts: arm r - f delta from the centre, f = 1/2 at the
    /// middle of the overlap (LIGGGHTS `cr = r - delta/2`), f = 1 on the wall
    /// surface (YADE's `ScGeom` contact point for `Ig2_Wall_Sphere_ScGeom`).
    pub wall_arm_overlap: f64,
}

/// Touching contacts found by a sweep.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContactCount {
    /// Contacts this rank owns: pairs whose lower-id particle is owned, and
    /// wall contacts (each contact is owned by exactly one rank).
    pub owned: usize,
    /// Contacts this rank evaluated (pairs across a subdomain boundary are
    /// evaluated on both sides): the work counter.
    pub evaluated: usize,
}

/// Compute forces and torques on the owned particles and this rank's part of
/// the load on every wall (`Wall::load`; `force` and `torque` are set from it
/// here, which for a single rank is the whole load).
pub fn compute_forces(
    s: &SweepSettings,
    p: &mut Particles,
    walls: &mut [Wall],
    nl: &mut NeighborList,
    table: &PairTable,
) -> ContactCount {
    match s.model {
        ContactModel::Hooke(l) => sweep(l, s, p, walls, nl, table),
        ContactModel::Hertz(l) => sweep(l, s, p, walls, nl, table),
    }
}

fn sweep<L: NormalLaw>(
    law: L,
    s: &SweepSettings,
    p: &mut Particles,
    walls: &mut [Wall],
    nl: &mut NeighborList,
    table: &PairTable,
) -> ContactCount {
    for i in 0..p.len() {
        p.force[i] = s.gravity * p.mass[i];
        p.torque[i] = Vec3::zeros();
    }
    // ellipses (2D): each body once per sweep (orientation sines and cosines)
    let shapes: Vec<ellipse::Ellipse> =
        if p.ellipse.iter().any(|&e| e) { (0..p.len()).map(|i| p.ellipse_of(i)).collect() } else { Vec::new() };
    let mut contacts = 0usize;
    let mut owned_pairs = 0usize;
    let n_own = p.owned();
    for (k, &(a, b)) in nl.pairs.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        let d = p.pos[a] - p.pos[b];
        let rsum = p.radius[a] + p.radius[b];
        let dist2 = d.norm_squared();
        let hist = &mut nl.pair_hist[k];
        // geometry, pair inertia, contact-point and shear velocities, and the
        // lever arms of an ellipse contact (None: along n, as for spheres)
        let found = if dist2 >= rsum * rsum {
            None
        } else if p.ellipse[a] || p.ellipse[b] {
            // ellipses (2D): contact geometry by the certified Newton search,
            // body 1 = b, body 2 = a, so n points from b to a as below
            let (ea, eb) = (&shapes[a], &shapes[b]);
            ellipse::contact_fast(eb, ea).map(|ec| {
                let n = ec.n;
                let (ra, rb) = (ec.point - p.pos[a], ec.point - p.pos[b]);
                // Hertz with the local radii of curvature at the contact
                let (rho_a, rho_b) = (ea.curvature_radius(-n.x, -n.y), eb.curvature_radius(n.x, n.y));
                let mut pi = nl.pair_inertia[k];
                pi.r_eff = rho_a * rho_b / (rho_a + rho_b);
                let g = ContactGeom { n, overlap: ec.overlap, arm_i: ra.norm(), arm_j: rb.norm() };
                let v = (p.vel[a] + p.omega[a].cross(&ra)) - (p.vel[b] + p.omega[b].cross(&rb));
                (g, pi, v, v, Some((ra, rb)))
            })
        } else {
            let dist = dist2.sqrt();
            let nrm = d * (1.0 / dist);
            let overlap = rsum - dist;
            let g = ContactGeom { n: nrm, overlap, arm_i: p.radius[a] - 0.5 * overlap, arm_j: p.radius[b] - 0.5 * overlap };
            let v = relative_velocity(&g, p.vel[a], p.vel[b], p.omega[a], p.omega[b]);
            let vs = match s.tang.kinematics {
                ShearKinematics::ContactPoint => v,
                ShearKinematics::FullRadii => yade_shear_velocity(
                    nrm, overlap, p.radius[a], p.radius[b], p.vel[a], p.vel[b], p.omega[a], p.omega[b],
                ),
            };
            Some((g, nl.pair_inertia[k], v, vs, None))
        };
        let Some((g, pi, v, vs, arms)) = found else {
            if *hist != Vec3::zeros() {
                *hist = Vec3::zeros();
            }
            continue;
        };
        contacts += 1;
        owned_pairs += (a < n_own) as usize;
        let pm = table.get(p.material[a], p.material[b]);
        let c = evaluate(law, s.end, s.tang, pm, pi, &g, v, vs, hist, s.dt);
        let (ta, tb) = match arms {
            Some((ra, rb)) => (ra.cross(&c.force), -rb.cross(&c.force)),
            None => torques(&g, c.force),
        };
        p.force[a] += c.force;
        p.force[b] -= c.force;
        p.torque[a] += ta;
        p.torque[b] += tb;
    }
    for w in walls.iter_mut() {
        w.load = [0; 6];
    }
    let mut wall_contacts = 0usize;
    let mut hits: Vec<Option<WallHit>> = Vec::with_capacity(16);
    for i in 0..n_own {
        let (lo, hi) = (nl.wall_start[i] as usize, nl.wall_start[i + 1] as usize);
        if lo == hi {
            continue;
        }
        // all of this particle's wall contacts first, so that coincident ones can
        // be merged and history can follow a contact from one triangle to the next
        hits.clear();
        for k in lo..hi {
            let (wi, feat) = nl.wall_feat[k];
            let wall = &walls[wi as usize];
            hits.push(match (wall.active, p.ellipse[i]) {
                (false, _) => None,
                (true, false) => wall.contact(feat, &p.pos[i], p.radius[i]),
                (true, true) => wall.ellipse_contact(feat, &shapes[i]),
            });
        }
        merge_coincident(&nl.wall_feat[lo..hi], &mut hits, p.radius[i]);
        carry_history(&nl.wall_feat[lo..hi], &hits, &mut nl.wall_hist[lo..hi]);
        for (k, hit) in hits.iter().enumerate() {
            let hist = &mut nl.wall_hist[lo + k];
            let Some(hit) = hit else {
                *hist = Vec3::zeros();
                continue;
            };
            let wall = &mut walls[nl.wall_feat[lo + k].0 as usize];
            wall_contacts += 1;
            // the point where the force acts (s.wall_arm_overlap of the overlap
            // back from the particle's deepest point), the radius of curvature
            // for R*, the velocities, and an ellipse's lever arm
            let (g, point, rho, v, vs, arm) = if p.ellipse[i] {
                // hit.point is the ellipse's deepest point
                let point = hit.point + hit.n * (s.wall_arm_overlap * hit.overlap);
                let ri = point - p.pos[i];
                let rho = shapes[i].curvature_radius(-hit.n.x, -hit.n.y);
                let g = ContactGeom { n: hit.n, overlap: hit.overlap, arm_i: ri.norm(), arm_j: 0.0 };
                let v = p.vel[i] + p.omega[i].cross(&ri) - wall.velocity;
                (g, point, rho, v, v, Some(ri))
            } else {
                let g = ContactGeom { n: hit.n, overlap: hit.overlap, arm_i: p.radius[i] - s.wall_arm_overlap * hit.overlap, arm_j: 0.0 };
                let v = relative_velocity(&g, p.vel[i], wall.velocity, p.omega[i], Vec3::zeros());
                let vs = match s.tang.kinematics {
                    ShearKinematics::ContactPoint => v,
                    ShearKinematics::FullRadii => yade_shear_velocity(
                        hit.n, hit.overlap, p.radius[i], 0.0, p.vel[i], wall.velocity, p.omega[i], Vec3::zeros(),
                    ),
                };
                // arm r - delta/2 along n
                (g, p.pos[i] - hit.n * g.arm_i, p.radius[i], v, vs, None)
            };
            let pi = match wall.curvature_radius() {
                None => PairInertia::wall(rho, p.mass[i]),
                Some(rw) => PairInertia::curved_wall(rho, rw, p.mass[i]),
            };
            let pm = table.get(p.material[i], wall.material);
            let c = evaluate(law, s.end, s.tang, pm, pi, &g, v, vs, hist, s.dt);
            let ti = match arm {
                Some(ri) => ri.cross(&c.force),
                None => torques(&g, c.force).0,
            };
            p.force[i] += c.force;
            p.torque[i] += ti;
            // the force acts on the wall at the same point as on the particle
            let t = point.cross(&c.force);
            for k in 0..3 {
                wall.load[k] -= to_fixed(c.force[k]);
                wall.load[3 + k] -= to_fixed(t[k]);
            }
        }
    }
    for w in walls.iter_mut() {
        w.force = Vec3::new(from_fixed(w.load[0]), from_fixed(w.load[1]), from_fixed(w.load[2]));
        w.torque = Vec3::new(from_fixed(w.load[3]), from_fixed(w.load[4]), from_fixed(w.load[5]));
    }
    ContactCount { owned: owned_pairs + wall_contacts, evaluated: contacts + wall_contacts }
}
