//! The force sweep: gravity, then particle pairs in list order, then walls in
//! wall and feature order. The law is chosen once per sweep
//! (`contact::dispatch`) and the kernel is monomorphised for it.
//!
//! Per contact, whatever the shapes: the geometry stage gives a
//! [`ContactGeom`] (`Shapes::pair`, `Shapes::wall`); the shared tail takes the
//! pair's material, R*, m* and law constants, the bodies' motion, and the law
//! returns the force and both torques, which are added to the particles (and
//! to the wall's load).

use crate::case::ContactSection;
use crate::contact::{dispatch, ContactForce, ContactGeom, ContactLaw, ContactOptions, LawUser, Motion, PairInertia, Shapes};
use crate::dim::Vec3;
use crate::fixed::from_fixed;
use crate::material::{PairMaterial, PairTable};
use crate::neighbor::NeighborList;
use crate::particles::Particles;
use crate::walls::{carry_history, merge_coincident, Wall, WallHit};

/// Everything the sweep needs besides state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepSettings {
    /// The case's `[contact]` section: the model and the law's own keys (the
    /// law is built from it once per sweep).
    pub contact: ContactSection,
    /// The conventions, resolved (`contact::conventions::resolve`).
    pub opts: ContactOptions,
    pub gravity: Vec3,
    pub dt: f64,
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
    struct Sweep<'a> {
        s: &'a SweepSettings,
        p: &'a mut Particles,
        walls: &'a mut [Wall],
        nl: &'a mut NeighborList,
        table: &'a PairTable,
    }
    impl LawUser for Sweep<'_> {
        type Out = ContactCount;
        fn with<L: ContactLaw>(self) -> ContactCount {
            let law = L::from_case(&self.s.contact, &self.s.opts).expect("the law's keys are checked when the case is loaded");
            sweep(law, self.s, self.p, self.walls, self.nl, self.table)
        }
    }
    dispatch(s.contact.model, Sweep { s, p, walls, nl, table })
}

/// The law's constants of every pair and wall candidate of the list
/// (`ContactLaw::pair`), once per list build.
fn law_constants<L: ContactLaw>(law: L, p: &Particles, walls: &[Wall], nl: &mut NeighborList, table: &PairTable) {
    if nl.law_constants.holds(law, nl.builds) {
        return;
    }
    let pairs = constants(nl.pairs.len(), |k| {
        let (a, b) = nl.pairs[k];
        law.pair(table.get(p.material[a as usize], p.material[b as usize]), nl.pair_inertia[k])
    });
    let mut i = 0; // the particle whose candidates hold k
    let consts = constants(nl.wall_feat.len(), |k| {
        while nl.wall_start[i + 1] as usize <= k {
            i += 1;
        }
        law.pair(table.get(p.material[i], walls[nl.wall_feat[k].0 as usize].material), nl.wall_inertia[k])
    });
    nl.law_constants.set(law, nl.builds, pairs, consts);
}

/// Constants 0..len made by `f`, in order. A law without any (a zero-sized
/// type, which carries nothing) needs no pass over the list: one stands for all.
fn constants<T: Copy>(len: usize, mut f: impl FnMut(usize) -> T) -> Vec<T> {
    if std::mem::size_of::<T>() == 0 && len > 0 {
        vec![f(0); len]
    } else {
        (0..len).map(f).collect()
    }
}

/// The shared tail's law part: where the geometry sets R* (ellipses), the
/// pair's R* and the law's constants are replaced by the contact's.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn contact<L: ContactLaw>(
    law: L,
    o: &ContactOptions,
    pm: &PairMaterial,
    pi: PairInertia,
    pair: &L::Pair,
    g: &ContactGeom,
    m: &Motion,
    hist: &mut Vec3,
    dt: f64,
) -> ContactForce {
    let (pi, pair) = match g.r_eff {
        None => (pi, *pair),
        Some(r_eff) => {
            let pi = PairInertia { r_eff, ..pi };
            (pi, law.pair(pm, pi))
        }
    };
    law.contact(o, pm, pi, &pair, g, m, hist, dt)
}

fn sweep<L: ContactLaw>(
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
    law_constants(law, p, walls, nl, table);
    let shapes = Shapes::new(p);
    let (evaluated, owned) = pair_forces(law, s, p, nl, table, &shapes);
    let wall_contacts = wall_forces(law, s, p, walls, nl, table, &shapes);
    ContactCount { owned: owned + wall_contacts, evaluated: evaluated + wall_contacts }
}

/// Pairs in any order, each contact's force and torques kept in `out`; then
/// every owned particle sums its own in order of its partners' ids
/// (`NeighborList::incident`): the same sums, bit for bit, whatever the order
/// of the pairs or of the particles in storage. Returns (contacts evaluated,
/// contacts owned).
fn pair_forces<L: ContactLaw>(
    law: L,
    s: &SweepSettings,
    p: &mut Particles,
    nl: &mut NeighborList,
    table: &PairTable,
    shapes: &Shapes,
) -> (usize, usize) {
    let (mut evaluated, mut owned) = (0usize, 0usize);
    let n_own = p.owned();
    let (consts, _) = nl.law_constants.get::<L>();
    // every entry is written below (touching or not): no clearing pass
    let out = &mut nl.pair_out;
    out.resize(nl.pairs.len(), None);
    for (k, &(a, b)) in nl.pairs.iter().enumerate() {
        let (a, b) = (a as usize, b as usize);
        let hist = &mut nl.pair_hist[k];
        let Some(g) = shapes.pair(p, a, b) else {
            if *hist != Vec3::zeros() {
                *hist = Vec3::zeros();
            }
            out[k] = None;
            continue;
        };
        evaluated += 1;
        owned += (a < n_own) as usize;
        let pm = table.get(p.material[a], p.material[b]);
        let m = Motion { v_i: p.vel[a], w_i: p.omega[a], v_j: p.vel[b], w_j: p.omega[b] };
        out[k] = Some(contact(law, &s.opts, pm, nl.pair_inertia[k], &consts[k], &g, &m, hist, s.dt));
    }
    for i in 0..n_own {
        let (lo, hi) = (nl.incident_start[i] as usize, nl.incident_start[i + 1] as usize);
        let (mut f, mut t) = (p.force[i], p.torque[i]);
        for &e in &nl.incident[lo..hi] {
            let Some(c) = &out[(e / 2) as usize] else { continue };
            if e % 2 == 0 {
                f += c.force;
                t += c.torque_i;
            } else {
                f -= c.force;
                t += c.torque_j;
            }
        }
        p.force[i] = f;
        p.torque[i] = t;
    }
    (evaluated, owned)
}

/// Walls, per owned particle in candidate order; returns the contacts.
fn wall_forces<L: ContactLaw>(
    law: L,
    s: &SweepSettings,
    p: &mut Particles,
    walls: &mut [Wall],
    nl: &mut NeighborList,
    table: &PairTable,
    shapes: &Shapes,
) -> usize {
    for w in walls.iter_mut() {
        w.load = [0; 6];
    }
    let (_, consts) = nl.law_constants.get::<L>();
    let mut contacts = 0usize;
    let mut hits: Vec<Option<WallHit>> = Vec::with_capacity(16);
    for i in 0..p.owned() {
        let (lo, hi) = (nl.wall_start[i] as usize, nl.wall_start[i + 1] as usize);
        if lo == hi {
            continue;
        }
        // all of this particle's wall contacts first, so that coincident ones can
        // be merged and history can follow a contact from one triangle to the next
        hits.clear();
        for &(wi, feat) in &nl.wall_feat[lo..hi] {
            hits.push(shapes.wall_hit(p, i, &walls[wi as usize], feat));
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
            contacts += 1;
            let g = shapes.wall(p, i, wall, hit, s.opts.wall_arm_overlap);
            let pm = table.get(p.material[i], wall.material);
            let m = Motion { v_i: p.vel[i], w_i: p.omega[i], v_j: wall.velocity, w_j: Vec3::zeros() };
            let c = contact(law, &s.opts, pm, nl.wall_inertia[lo + k], &consts[lo + k], &g, &m, hist, s.dt);
            p.force[i] += c.force;
            p.torque[i] += c.torque_i;
            // the force acts on the wall at the same point as on the particle
            wall.add_load(g.point(p.pos[i]), &c);
        }
    }
    for w in walls.iter_mut() {
        w.force = Vec3::new(from_fixed(w.load[0]), from_fixed(w.load[1]), from_fixed(w.load[2]));
        w.torque = Vec3::new(from_fixed(w.load[3]), from_fixed(w.load[4]), from_fixed(w.load[5]));
    }
    contacts
}
