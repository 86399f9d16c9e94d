//! The force sweep: gravity, then every particle's pair forces in order of its
//! partners' ids, those of higher id (its own row, summed as the row is
//! evaluated), then those of lower id, then walls in wall and feature order. The law is chosen once per sweep
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
use crate::neighbor::{row_blocks_of, NeighborList, PairOut, ROW_BLOCK};
use crate::particles::Particles;
use crate::prefetch::prefetch;
use crate::walls::{add_load, carry_history, merge_coincident, Wall, WallHit};
use rayon::prelude::*;
use std::sync::atomic::Ordering;

/// Fewest pairs or particles a thread takes at once. A sweep over at most
/// 2 MIN_LEN of each is never split, so it runs on the calling thread.
pub const MIN_LEN: usize = 256;

/// How many particles ahead the gather fetches the places of the pair results
/// it will read.
const PREFETCH: usize = 6;

/// How many pairs ahead the pair sweep fetches the partner's position,
/// velocity and spin (the cell order keeps them near, but not in order:
/// loads the processor cannot foresee).
const ROW_PREFETCH: usize = 8;

/// Everything the sweep needs besides state.
#[derive(Clone, Debug, PartialEq)]
pub struct SweepSettings {
    /// The case's `[contact]` section: the model and the law's own keys (the
    /// law is built from it once per sweep).
    pub contact: ContactSection,
    /// The conventions, resolved (`contact::conventions::resolve`).
    pub opts: ContactOptions,
    pub gravity: Vec3,
    pub dt: f64,
    /// Fewest pairs or particles a thread takes at once: `MIN_LEN` on several
    /// threads, `usize::MAX` on one (nothing is split: the sweep runs on the
    /// calling thread and never touches a pool).
    pub grain: usize,
    /// The period along each axis (m; zero where the domain is not periodic).
    pub period: Vec3,
    /// Keep every wall contact of the sweep in `NeighborList::wall_records`
    /// (the continuum fields' stress needs each one's force and point).
    pub record_walls: bool,
}

/// A wall contact as the sweep saw it (kept where `SweepSettings::record_walls`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallContact {
    /// The particle (storage place).
    pub particle: u32,
    pub wall: u16,
    /// The force on the particle (N).
    pub force: Vec3,
    /// The contact point (m).
    pub point: Vec3,
    /// The particle's centre, or the periodic image's that touches (m).
    pub centre: Vec3,
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
    dispatch(&s.contact, Sweep { s, p, walls, nl, table })
}

/// The law's constants of every pair and wall candidate of the list
/// (`ContactLaw::pair`), once per list build (the pairs' on the pool's
/// threads unless `grain` says one thread).
fn law_constants<L: ContactLaw>(law: L, p: &Particles, walls: &[Wall], nl: &mut NeighborList, table: &PairTable, grain: usize) {
    if nl.law_constants.holds(law, nl.builds) {
        return;
    }
    let pair = |k: usize| {
        let (a, b) = nl.pairs[k];
        let (a, b) = (a as usize, b as usize);
        law.pair(table.get(p.material[a], p.material[b]), PairInertia::particles(p.radius[a], p.radius[b], p.mass[a], p.mass[b]))
    };
    // written into the last build's room
    let (mut pairs, mut consts) = nl.law_constants.take_buffers::<L>();
    if std::mem::size_of::<L::Pair>() == 0 || grain == usize::MAX {
        constants(&mut pairs, nl.pairs.len(), pair);
    } else {
        pairs.par_extend((0..nl.pairs.len()).into_par_iter().with_min_len(grain).map(pair));
    }
    let mut i = 0; // the particle whose candidates hold k
    constants(&mut consts, nl.wall_feat.len(), |k| {
        while nl.wall_start[i + 1] as usize <= k {
            i += 1;
        }
        law.pair(table.get(p.material[i], walls[nl.wall_feat[k].0 as usize].material), nl.wall_inertia[k])
    });
    nl.law_constants.set(law, nl.builds, pairs, consts);
}

/// Constants 0..len made by `f`, in order, written into `v` (empty). A law
/// without any (a zero-sized type, which carries nothing) needs no pass over
/// the list: one stands for all.
fn constants<T: Copy>(v: &mut Vec<T>, len: usize, mut f: impl FnMut(usize) -> T) {
    if std::mem::size_of::<T>() == 0 && len > 0 {
        v.resize(len, f(0));
    } else {
        v.extend((0..len).map(f));
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
    roll: &mut Vec3,
    dt: f64,
) -> ContactForce {
    let (pi, pair) = match g.r_eff {
        None => (pi, *pair),
        Some(r_eff) => {
            let pi = PairInertia { r_eff, ..pi };
            (pi, law.pair(pm, pi))
        }
    };
    law.contact(o, pm, pi, &pair, g, m, hist, roll, dt)
}

fn sweep<L: ContactLaw>(
    law: L,
    s: &SweepSettings,
    p: &mut Particles,
    walls: &mut [Wall],
    nl: &mut NeighborList,
    table: &PairTable,
) -> ContactCount {
    // gravity: in the pair sweep (`pair_forces`), which writes every
    // particle's force and torque
    law_constants(law, p, walls, nl, table, s.grain);
    let shapes = Shapes::new(p, &s.period);
    let (evaluated, owned) = pair_forces(law, s, p, nl, table, &shapes);
    let wall_contacts = wall_forces(law, s, p, walls, nl, table, &shapes);
    ContactCount { owned: owned + wall_contacts, evaluated: evaluated + wall_contacts }
}

/// Pairs row by row, blocks of rows on the pool's threads: each pair's force
/// and torques are computed once, where the list keeps it (the row of a, its
/// lower id). Particle a adds its own part at once, in its row's order (its
/// partners of higher id, by id), to its weight; b's part is kept in
/// `pair_out`, packed: the touching pairs of a block of rows one after the
/// other, each pair's place in `pair_slot` (the last entry, zeros, for a
/// pair that does not touch). Then every owned particle takes away what its partners of
/// lower id put on it, in order of their ids (`NeighborList::incident`): the
/// same sums, bit for bit, whatever the order of the pairs or of the
/// particles in storage, and whatever the thread count. Returns (contacts
/// evaluated, contacts owned).
fn pair_forces<L: ContactLaw>(
    law: L,
    s: &SweepSettings,
    p: &mut Particles,
    nl: &mut NeighborList,
    table: &PairTable,
    shapes: &Shapes,
) -> (usize, usize) {
    let n_own = p.owned();
    let (consts, _) = nl.law_constants.get::<L>();
    // which particles are b of a touching pair (set by any thread, read
    // after: the value does not depend on the order), so the gather skips
    // the others
    let touched = nl.touched.reset(p.len());
    // the rows' sums go straight into the forces and torques (every row's:
    // a ghost's is set back to its weight after)
    let (mut force, mut torque) = (std::mem::take(&mut p.force), std::mem::take(&mut p.torque));
    let pr: &Particles = p;
    let ev = PairEval { law, s, pr, shapes, table, touched, n_own, consts, pairs: &nl.pairs };
    let start = &nl.row_start;
    let n = pr.len();
    // the rolling spring torques where the law keeps them (epsd2), else none:
    // two monomorphised sweeps, so that the laws without add nothing per pair
    let rolling = nl.pair_roll.len() == nl.pairs.len() && !nl.pairs.is_empty();
    let (hist, roll, slot, out) = (&mut nl.pair_hist, &mut nl.pair_roll, &mut nl.pair_slot, &mut nl.pair_out);
    let counts = if s.grain == usize::MAX || n <= 2 * ROW_BLOCK {
        let rows = Rows { first: 0, hist, roll, slot, out, force: &mut force, torque: &mut torque };
        if rolling { ev.rows::<true>(rows, start) } else { ev.rows::<false>(rows, start) }
    } else {
        // at most ROW_BLOCK rows a block, and at least eight blocks a thread
        // where the system is small (a few thousand particles in three
        // blocks would leave a thread idle a third of the sweep)
        let block = (n / (8 * rayon::current_num_threads())).clamp(MIN_LEN, ROW_BLOCK);
        let roll_blocks = if rolling { row_blocks_of(roll, start, n, block) } else { Vec::new() };
        let mut roll_blocks = roll_blocks.into_iter();
        let blocks: Vec<_> = row_blocks_of(hist, start, n, block)
            .into_iter()
            .zip(row_blocks_of(slot, start, n, block))
            .zip(row_blocks_of(out, start, n, block))
            .zip(force.chunks_mut(block).zip(torque.chunks_mut(block)))
            .map(|((((range, hist), (_, slot)), (_, out)), (force, torque))| {
                let roll: &mut [Vec3] = roll_blocks.next().map_or(&mut [], |x| x.1);
                Rows { first: range.start, hist, roll, slot, out, force, torque }
            })
            .collect();
        blocks
            .into_par_iter()
            .map(|rows| if rolling { ev.rows::<true>(rows, start) } else { ev.rows::<false>(rows, start) })
            .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1))
    };
    p.force = force;
    p.torque = torque;
    // the ghosts': their weight (nothing of theirs is summed on this rank)
    for i in n_own..n {
        p.force[i] = s.gravity * p.mass[i];
        p.torque[i] = Vec3::zeros();
    }
    let (start, incident, out, slot, touched) = (&nl.incident_start, &nl.incident, &nl.pair_out, &nl.pair_slot, &*touched);
    let gather = |(i, (f, t)): (usize, (&mut Vec3, &mut Vec3))| {
        // the pair results a later particle will read, fetched ahead
        if i + PREFETCH < n_own {
            let j = i + PREFETCH;
            for &k in &incident[start[j] as usize..start[j + 1] as usize] {
                prefetch(slot, k as usize);
            }
        }
        if !touched[i].load(Ordering::Relaxed) {
            return;
        }
        // partners of lower id (i is the pair's b), in order of id: the
        // zeros (the last entry) for those that do not touch change nothing (f - 0 is f, and a
        // torque sum, which starts at +0, is never -0, so t + 0 is t), and
        // cost less than a test (a branch the processor cannot predict)
        // (summed in locals, which stay in registers)
        let (mut fs, mut ts) = (*f, *t);
        for &k in &incident[start[i] as usize..start[i + 1] as usize] {
            let c = &out[slot[k as usize] as usize];
            fs -= c.force;
            ts += c.torque_b;
        }
        *f = fs;
        *t = ts;
    };
    if s.grain == usize::MAX {
        p.force[..n_own].iter_mut().zip(p.torque[..n_own].iter_mut()).enumerate().for_each(gather);
    } else {
        p.force[..n_own].par_iter_mut().zip(p.torque[..n_own].par_iter_mut()).enumerate().with_min_len(s.grain).for_each(gather);
    }
    counts
}

/// What every pair's evaluation reads (see [`pair_forces`]).
struct PairEval<'a, L: ContactLaw> {
    law: L,
    s: &'a SweepSettings,
    pr: &'a Particles,
    shapes: &'a Shapes,
    table: &'a PairTable,
    touched: &'a [std::sync::atomic::AtomicBool],
    n_own: usize,
    consts: &'a [L::Pair],
    pairs: &'a [(u32, u32)],
}

/// The rows of particles `first..first + force.len()`: their pairs' history,
/// rolling spring torques (empty unless the law keeps them), places of b's
/// parts (`NeighborList::pair_slot`) and room for them (from the rows' first
/// pair on), and the particles' sums.
struct Rows<'a> {
    first: usize,
    hist: &'a mut [Vec3],
    roll: &'a mut [Vec3],
    slot: &'a mut [u32],
    out: &'a mut [PairOut],
    force: &'a mut [Vec3],
    torque: &'a mut [Vec3],
}

impl<L: ContactLaw> PairEval<'_, L> {
    /// Every pair of these rows: its force and torques, a's part summed into
    /// a's force and torque from a's weight (in row order), b's kept in `out`,
    /// the touching pairs' one after the other, each pair's place in `slot`
    /// ([`zero_slot`] where it does not touch). `ROLL`: the law keeps rolling
    /// spring torques. Returns (contacts evaluated, contacts owned).
    fn rows<const ROLL: bool>(&self, r: Rows<'_>, start: &[u32]) -> (usize, usize) {
        let PairEval { law, s, pr, shapes, table, touched, n_own, consts, pairs } = *self;
        if r.force.is_empty() {
            return (0, 0);
        }
        let base = start[r.first] as usize;
        let (mut evaluated, mut owned) = (0, 0);
        let inertia = L::USES_INERTIA || s.opts.rolling.is_some();
        let Rows { first, hist, roll, slot, out, force, torque } = r;
        let zero = zero_slot(pairs);
        // the next free place in `out` (this block's touching pairs so far)
        let mut packed = 0usize;
        // the sums start from the weight and no torque, and take each pair
        // of the row in turn (one pass over the pairs of all these rows)
        for (a, (f, t)) in (first..).zip(force.iter_mut().zip(torque.iter_mut())) {
            *f = s.gravity * pr.mass[a];
            *t = Vec3::zeros();
        }
        let k1 = start[first + force.len()] as usize;
        let all = pairs[base..k1].iter().zip(hist.iter_mut()).zip(slot.iter_mut()).zip(&consts[base..k1]).enumerate();
        for (j, (((&(a, b), hist), slot), pair)) in all {
            let (a, b) = (a as usize, b as usize);
            if base + j + ROW_PREFETCH < k1 {
                let c = pairs[base + j + ROW_PREFETCH].1 as usize;
                prefetch(&pr.pos, c);
                prefetch(&pr.vel, c);
                prefetch(&pr.omega, c);
            }
            // a contact that reaches beyond touching (JKR) goes on while it
            // touched at the last step: its mark is kept in the second history
            // slot, carried with the shear history over list builds,
            // checkpoints and ranks (`reaching`)
            let g = if L::REACHES && ROLL && reaching(&roll[j]) { shapes.pair_within(pr, a, b, law.reach(pair)) } else { shapes.pair(pr, a, b) };
            let Some(g) = g else {
                if *hist != Vec3::zeros() {
                    *hist = Vec3::zeros();
                }
                if ROLL {
                    roll[j] = Vec3::zeros();
                }
                *slot = zero;
                continue;
            };
            let pm = table.get(pr.material[a], pr.material[b]);
            // R*, m*: computed here, where the pair touches (a list of
            // them would be read and written far more often), where the
            // law or the rolling resistance reads them
            let pi = if inertia { PairInertia::particles(pr.radius[a], pr.radius[b], pr.mass[a], pr.mass[b]) } else { PairInertia::UNUSED };
            let m = Motion { v_i: pr.vel[a], w_i: pr.omega[a], v_j: pr.vel[b], w_j: pr.omega[b] };
            let mut no_roll = Vec3::zeros();
            let roll = if ROLL { &mut roll[j] } else { &mut no_roll };
            let c = contact(law, &s.opts, pm, pi, pair, &g, &m, hist, roll, s.dt);
            if L::REACHES {
                *roll = TOUCHING;
            }
            out[packed] = PairOut { force: c.force, torque_b: c.torque_j };
            *slot = (base + packed) as u32;
            packed += 1;
            force[a - first] += c.force;
            torque[a - first] += c.torque_i;
            touched[b].store(true, Ordering::Relaxed);
            evaluated += 1;
            // a contact beyond touching (JKR) pulls, but the bodies do not touch:
            // counted as LAMMPS's contact/atom counts (overlap > 0)
            owned += (a < n_own && (!L::REACHES || g.overlap > 0.0)) as usize;
        }
        (evaluated, owned)
    }
}

/// The place in `pair_out` of the zeros that a pair which does not touch
/// points at (`NeighborList::pair_slot`): the entry after the last pair's.
#[inline(always)]
pub fn zero_slot(pairs: &[(u32, u32)]) -> u32 {
    pairs.len() as u32
}

/// A law that reaches beyond touching (`ContactLaw::REACHES`, JKR) marks
/// each contact that touches in its second history slot (the rolling
/// spring's, which such a law does not keep: jkr refuses `epsd2`), so that
/// the mark is carried wherever history is: over list builds, into
/// checkpoints, across ranks. Zero: not touching at the last step.
pub const TOUCHING: Vec3 = Vec3::new(1.0, 0.0, 0.0);

/// Whether a contact's second history slot holds the mark [`TOUCHING`].
#[inline(always)]
fn reaching(slot: &Vec3) -> bool {
    *slot == TOUCHING
}

/// Walls, per owned particle in candidate order (the particles with wall
/// candidates in parallel; each thread sums its part of every wall's load
/// exactly, in fixed point, so the total is the same for any thread count);
/// returns the contacts.
fn wall_forces<L: ContactLaw>(
    law: L,
    s: &SweepSettings,
    p: &mut Particles,
    walls: &mut [Wall],
    nl: &mut NeighborList,
    table: &PairTable,
    shapes: &Shapes,
) -> usize {
    let (_, consts) = nl.law_constants.get::<L>();
    let (wall_start, wall_feat, wall_inertia, owners) = (&nl.wall_start, &nl.wall_feat, &nl.wall_inertia, &nl.wall_owners);
    let wall_image = &nl.wall_image;
    // each such particle's slice of the wall history (the others' are empty)
    // (and of the rolling spring torques where the law keeps them; else empty slices)
    let mut hist: Vec<(&mut [Vec3], &mut [Vec3])> = Vec::with_capacity(owners.len());
    let rolling = nl.wall_roll.len() == nl.wall_hist.len() && !nl.wall_hist.is_empty();
    let mut rest: &mut [Vec3] = &mut nl.wall_hist;
    let mut rest_roll: &mut [Vec3] = &mut nl.wall_roll;
    for &i in owners {
        let len = (wall_start[i as usize + 1] - wall_start[i as usize]) as usize;
        let (h, r) = std::mem::take(&mut rest).split_at_mut(len);
        let (hr, rr) = std::mem::take(&mut rest_roll).split_at_mut(if rolling { len } else { 0 });
        hist.push((h, hr));
        rest = r;
        rest_roll = rr;
    }
    let pr: &Particles = p;
    let ws: &[Wall] = walls;
    let record = s.record_walls;
    type Part = (Vec<[i128; 6]>, usize, Vec<(u32, Vec3, Vec3)>, Vec<Option<WallHit>>, Vec<WallContact>);
    let empty = || -> Part { (vec![[0i128; 6]; ws.len()], 0, Vec::new(), Vec::with_capacity(16), Vec::new()) };
    let (loads, contacts, updates, _, records) = hist
        .into_par_iter()
        .zip(owners.par_iter())
        .with_min_len((s.grain / 4).max(1))
        .fold(empty, |(mut loads, mut contacts, mut updates, mut hits, mut records), ((hist, roll), &i)| {
            let i = i as usize;
            let (lo, hi) = (wall_start[i] as usize, wall_start[i + 1] as usize);
            // all of this particle's wall contacts first, so that coincident ones can
            // be merged and history can follow a contact from one triangle to the next
            hits.clear();
            // where the particle meets each candidate: itself, or the periodic image the candidate is of
            let at = |k: usize| match wall_image.get(k) {
                Some(g) => pr.pos[i] + crate::particles::image_shift(g, &s.period),
                None => pr.pos[i],
            };
            for (k, &(wi, feat)) in wall_feat[lo..hi].iter().enumerate() {
                // a contact that reaches beyond touching goes on while it touched at the last step
                let reach = if L::REACHES && roll.get(k).is_some_and(reaching) { law.reach(&consts[lo + k]) } else { 0.0 };
                hits.push(shapes.wall_hit_within(pr, i, &at(lo + k), &ws[wi as usize], feat, reach));
            }
            merge_coincident(&wall_feat[lo..hi], &mut hits, pr.radius[i]);
            carry_history(&wall_feat[lo..hi], &hits, hist, roll);
            let (mut f, mut t) = (pr.force[i], pr.torque[i]);
            let mut no_roll = Vec3::zeros();
            for (k, hit) in hits.iter().enumerate() {
                let h = &mut hist[k];
                let r = roll.get_mut(k).unwrap_or(&mut no_roll);
                let Some(hit) = hit else {
                    *h = Vec3::zeros();
                    *r = Vec3::zeros();
                    continue;
                };
                let wi = wall_feat[lo + k].0 as usize;
                let wall = &ws[wi];
                let g = shapes.wall(pr, i, wall, hit, s.opts.wall_arm_overlap);
                contacts += (!L::REACHES || g.overlap > 0.0) as usize;
                let pm = table.get(pr.material[i], wall.material);
                // the force acts on the wall at the same point as on the particle, which
                // moves with the wall's velocity there (a turning wall's rotation included)
                let point = g.point(at(lo + k));
                let m = Motion { v_i: pr.vel[i], w_i: pr.omega[i], v_j: wall.velocity_at(point), w_j: Vec3::zeros() };
                let c = contact(law, &s.opts, pm, wall_inertia[lo + k], &consts[lo + k], &g, &m, h, r, s.dt);
                if L::REACHES {
                    *r = TOUCHING;
                }
                f += c.force;
                t += c.torque_i;
                add_load(&mut loads[wi], point, &c);
                if record {
                    records.push(WallContact { particle: i as u32, wall: wi as u16, force: c.force, point, centre: at(lo + k) });
                }
            }
            updates.push((i as u32, f, t));
            (loads, contacts, updates, hits, records)
        })
        .reduce(empty, |(mut a, ca, mut ua, h, mut ra), (b, cb, ub, _, rb)| {
            for (x, y) in a.iter_mut().zip(&b) {
                for k in 0..6 {
                    x[k] += y[k];
                }
            }
            ua.extend(ub);
            ra.extend(rb);
            (a, ca + cb, ua, h, ra)
        });
    nl.wall_records = records;
    for (i, f, t) in updates {
        p.force[i as usize] = f;
        p.torque[i as usize] = t;
    }
    for (w, l) in walls.iter_mut().zip(loads) {
        w.load = l;
        w.force = Vec3::new(from_fixed(l[0]), from_fixed(l[1]), from_fixed(l[2]));
        w.torque = Vec3::new(from_fixed(l[3]), from_fixed(l[4]), from_fixed(l[5]));
    }
    contacts
}
