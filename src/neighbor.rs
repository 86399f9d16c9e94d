//! Neighbour search: a cell grid feeds Verlet lists with a skin. The lists are
//! rebuilt when the two particles that moved most since the last build have
//! moved more than the skin between them (`Moved::stale`). Cost per build is linear in N: particles are binned in cells (a
//! quarter of the interaction range along x, the whole range along y and z),
//! and each pair is found once, by the particle that comes first in the
//! grid's order, from half the 3 x 3 runs of cells around it.
//!
//! Each pair is (a, b) with id_a < id_b, in storage order of a. Every owned
//! particle keeps its pairs in order of its partners' global ids
//! (`incident`), and the force sweep sums its pair forces in order of
//! partner id (its row's, then these), whatever the storage order, the order
//! of the pairs or the rank: the foundation of results that do not depend on
//! how particles are stored or split among ranks.

use crate::contact::{ContactLaw, PairInertia};
use crate::dim::Vec3;
use crate::error::TalusError;
use crate::particles::Particles;
use crate::prefetch::prefetch;
use crate::walls::Wall;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Axis-aligned box that particles must stay inside.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct Domain {
    pub lo: Vec3,
    pub hi: Vec3,
}

/// One contact's history: the shear spring's, and the rolling spring's torque
/// where the case's rolling law keeps one (`epsd2`; zero otherwise).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq)]
pub struct Hist {
    pub shear: Vec3,
    pub roll: Vec3,
}

impl Hist {
    pub const ZERO: Hist = Hist { shear: Vec3::new(0.0, 0.0, 0.0), roll: Vec3::new(0.0, 0.0, 0.0) };
    #[inline(always)]
    pub fn is_zero(&self) -> bool {
        *self == Hist::ZERO
    }

    /// Entry k of a list's shear and rolling arrays (the rolling array is
    /// empty where the case keeps no rolling history).
    #[inline(always)]
    pub fn at(shear: &[Vec3], roll: &[Vec3], k: usize) -> Hist {
        Hist { shear: shear[k], roll: roll.get(k).copied().unwrap_or_else(Vec3::zeros) }
    }

    /// Entry k, as the history read out by ids has it: a zero history is no
    /// history, so a -0 reads as +0 (the bits then match the keyed path).
    #[inline(always)]
    fn kept_at(shear: &[Vec3], roll: &[Vec3], k: usize) -> Hist {
        let h = Hist::at(shear, roll, k);
        if h.is_zero() {
            Hist::ZERO
        } else {
            h
        }
    }
}

/// Contact history keyed by global ids: pairs (id_a < id_b) and particle-wall
/// features (id, wall, feature), each sorted by key. This is what migrates with
/// particles between ranks and what a checkpoint stores.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct History {
    pub pairs: Vec<((u64, u64), Hist)>,
    pub walls: Vec<((u64, u16, u32), Hist)>,
}

impl History {
    /// Merge another sorted, deduplicated history into this one (equal keys once).
    pub fn merge(&mut self, other: History) {
        fn merge_sorted<K: Ord + Copy>(a: &mut Vec<(K, Hist)>, b: Vec<(K, Hist)>) {
            let old = std::mem::take(a);
            a.reserve(old.len() + b.len());
            let (mut i, mut j) = (0, 0);
            while i < old.len() || j < b.len() {
                if j == b.len() || (i < old.len() && old[i].0 < b[j].0) {
                    a.push(old[i]);
                    i += 1;
                } else if i == old.len() || b[j].0 < old[i].0 {
                    a.push(b[j]);
                    j += 1;
                } else {
                    a.push(old[i]);
                    i += 1;
                    j += 1;
                }
            }
        }
        merge_sorted(&mut self.pairs, other.pairs);
        merge_sorted(&mut self.walls, other.walls);
    }

    /// Sort by key and drop repeated keys (a pair shared by two ranks arrives twice, with equal values).
    pub fn normalise(&mut self) {
        self.pairs.sort_unstable_by_key(|x| x.0);
        self.pairs.dedup_by_key(|x| x.0);
        self.walls.sort_unstable_by_key(|x| x.0);
        self.walls.dedup_by_key(|x| x.0);
    }
}

/// Candidate particle pairs and particle-wall features with their contact history.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct NeighborList {
    pub skin: f64,
    /// Local index pairs (a, b) with id[a] < id[b], in storage order of a.
    pub pairs: Vec<(u32, u32)>,
    pub pair_hist: Vec<Vec3>,
    /// Each pair's rolling spring torque where the case's rolling law keeps
    /// one (`rolling_history`), else empty.
    #[serde(default)]
    pub pair_roll: Vec<Vec3>,
    /// Whether contacts keep a rolling spring torque (`contact.rolling = "epsd2"`).
    #[serde(default)]
    pub rolling_history: bool,
    /// Particle -> range in `wall_feat`.
    pub wall_start: Vec<u32>,
    /// (wall index, feature index).
    pub wall_feat: Vec<(u16, u32)>,
    pub wall_hist: Vec<Vec3>,
    /// Each wall candidate's periodic image of the particle (periodic domains
    /// only, else empty): a wall near one periodic face touches the particles
    /// near the other at their image's place.
    #[serde(skip)]
    pub wall_image: Vec<[i32; 3]>,
    /// The wall contacts of the last force sweep, where it keeps them
    /// (`SweepSettings::record_walls`; else empty).
    #[serde(skip)]
    pub wall_records: Vec<crate::forces::WallContact>,
    /// Each wall candidate's rolling spring torque (as `pair_roll`).
    #[serde(default)]
    pub wall_roll: Vec<Vec3>,
    /// R*, m*, sqrt(m*) of each wall candidate (the particle against a flat or
    /// curved wall; computed at build; a pair's are computed where it touches,
    /// from the two particles, `PairInertia::particles`).
    #[serde(skip)]
    pub wall_inertia: Vec<PairInertia>,
    /// The law's constants of every pair and wall candidate (rebuilt with the list).
    #[serde(skip)]
    pub law_constants: LawConstants,
    /// Particle a's pairs (as the lower id, `a` of the pair) are
    /// `pairs[row_start[a]..row_start[a + 1]]`, in order of the partners' ids
    /// (every particle, ghosts included).
    #[serde(skip)]
    pub row_start: Vec<u32>,
    /// The pairs in which an owned particle is the higher id (`b`), each
    /// particle's in order of its partners' ids: particle i's are
    /// `incident[incident_start[i]..incident_start[i + 1]]` (pair indices).
    /// The force sweep sums a particle's row (its partners of higher id, by
    /// id) as it evaluates the row, then takes away these, by id: the sum
    /// does not depend on the order of the pairs or of the particles in
    /// storage.
    #[serde(skip)]
    pub incident_start: Vec<u32>,
    #[serde(skip)]
    pub incident: Vec<u32>,
    /// Work space of `build_incident`.
    #[serde(skip)]
    pub incident_keyed: Vec<(u64, u32)>,
    /// Work space of `build_pairs`: the pairs found (one thread) and the rows
    /// as (partner id, partner).
    #[serde(skip)]
    pub found: Vec<(u32, u32)>,
    #[serde(skip)]
    pub row_keyed: Vec<(u64, u32)>,
    /// Where each pair's part for its b sits in `pair_out` after the last
    /// sweep: packed, the touching pairs of a block of rows one after the
    /// other; a pair that does not touch points at the zeros after the last
    /// pair's place (`forces::zero_slot`), so the gather reads four bytes,
    /// not 48, for each of the many pairs of a list that do not touch.
    #[serde(skip)]
    pub pair_slot: Vec<u32>,
    /// Whether each particle is the b (higher id) of a touching pair at this
    /// sweep (work space of the force sweep, kept to spare an allocation a
    /// step).
    #[serde(skip)]
    pub touched: TouchFlags,
    /// The owned particles that have wall candidates, in storage order.
    #[serde(skip)]
    pub wall_owners: Vec<u32>,
    /// The touching pairs' parts for their b from the last sweep (force,
    /// torque on b), at the places `pair_slot` gives, and one entry of zeros
    /// at the end.
    #[serde(skip)]
    pub pair_out: Vec<PairOut>,
    /// Whether the list is built on the rank's threads (the caller runs the
    /// build inside the rank's pool); results do not depend on it.
    #[serde(skip)]
    pub threaded: bool,
    /// The period along each axis (m; zero where the domain is not periodic):
    /// the list sees each particle at `Particles::list_pos`.
    #[serde(skip)]
    pub period: Vec3,
    /// The particles' ids at the last build: the next build on one rank
    /// carries the contact history from the list itself ([`Carry::Own`]).
    #[serde(skip)]
    pub ids: Vec<u64>,
    /// The arrays of the build before the last (work space): a build writes
    /// its rows into these, reading the history from the last build's.
    #[serde(skip)]
    pub spare: Spare,
    /// Positions at the last build (as the list saw them).
    pub x_ref: Vec<Vec3>,
    /// How a build gives each particle its skin ([`SkinRule`]; set from the
    /// case, not kept in checkpoints).
    #[serde(skip)]
    pub skin_rule: SkinRule,
    /// The largest skin a build may give a particle (m; at least `skin`):
    /// what the ghosts cover on several ranks (`Parallel::skin_limit`).
    #[serde(skip)]
    pub skin_limit: f64,
    /// Each particle's skin at the last build (m; owned, then ghosts), where
    /// not all are `skin` (`uniform`).
    #[serde(skip)]
    pub skins: Vec<f64>,
    /// Whether every particle was listed with `skin` at the last build.
    #[serde(skip)]
    pub uniform: bool,
    /// Largest distance any wall has moved since the last build (m).
    pub wall_moved: f64,
    /// At least the largest growth of any particle's radius since the last
    /// build (m; `Simulation::set_radii`, which keeps the list where it can).
    #[serde(default)]
    pub grown: f64,
    pub builds: u64,
}

/// A particle's skin at a build: s_k = 2 |v_k| dt N, at least the case's
/// skin and at most `cap` times it, so that a particle that keeps its speed
/// uses up half its skin in N steps (`SKIN_STEPS`) where the case's skin
/// would last it fewer. A list is stale once the two largest d_k - s_k / 2
/// add up to more than zero ([`Moved::stale`]): where a few particles fall
/// fast through a slow pile (a hopper's discharge), they no longer decide
/// alone how often the whole list is rebuilt. Off (every s_k the skin) where
/// `per_speed` is 0: the default, and in periodic domains (whose period is
/// checked against one skin).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SkinRule {
    /// 2 dt N (s).
    pub per_speed: f64,
    /// The largest skin as a multiple of the case's.
    pub cap: f64,
}

/// Steps a fast particle's skin lasts it (`SkinRule`).
pub const SKIN_STEPS: f64 = 25.0;
/// The largest skin, as a multiple of the case's (`SkinRule`).
pub const SKIN_CAP: f64 = 4.0;

impl SkinRule {
    /// The rule for time step `dt`.
    pub fn new(dt: f64) -> SkinRule {
        SkinRule { per_speed: 2.0 * dt * SKIN_STEPS, cap: SKIN_CAP }
    }

    /// The skin of a particle of speed `speed` (m/s), the case's skin being
    /// `skin` and the largest allowed `limit` (a NaN speed gets the largest).
    #[inline]
    pub fn of(&self, skin: f64, limit: f64, speed: f64) -> f64 {
        if self.per_speed == 0.0 {
            return skin;
        }
        (self.per_speed * speed).min(self.cap * skin).min(limit).max(skin)
    }
}

/// Where a build takes the contact history from.
#[derive(Clone, Copy, Debug)]
pub enum Carry<'a> {
    /// Keyed by global ids, sorted by key (several ranks; a restart).
    Keyed(&'a History),
    /// The list's own, from the last build (one rank): pair by pair along
    /// the rows where the particles are those of the last build in the same
    /// storage order, else looked up row by row through the places the
    /// particles had then (as `OwnAnd` with nothing received).
    Own,
    /// The list's own, each particle's row found through the place its id
    /// had at the last build, and where a pair or wall candidate has no
    /// history there, the one received (`arrived`, sorted by key: the
    /// history that came with particles from other ranks). The same values
    /// as the keyed history of the particles that stay merged with
    /// `arrived`: a pair held on two ranks has the same history on both,
    /// bit for bit. Where an id is held twice (periodic images) the
    /// history is read out by ids and merged instead.
    OwnAnd(&'a History),
}

/// A list's arrays kept from the build before the last (see `NeighborList::spare`).
#[derive(Clone, Debug, Default)]
pub struct Spare {
    pairs: Vec<(u32, u32)>,
    hist: Vec<Vec3>,
    roll: Vec<Vec3>,
    row_start: Vec<u32>,
    wall_start: Vec<u32>,
    wall_feat: Vec<(u16, u32)>,
    wall_hist: Vec<Vec3>,
    wall_roll: Vec<Vec3>,
}

/// One flag a particle, set by any thread of the force sweep and read after it.
#[derive(Default)]
pub struct TouchFlags(Vec<std::sync::atomic::AtomicBool>);

impl TouchFlags {
    /// `n` flags, all down (the buffer is kept between calls).
    pub fn reset(&mut self, n: usize) -> &[std::sync::atomic::AtomicBool] {
        use std::sync::atomic::{AtomicBool, Ordering};
        self.0.truncate(n);
        for f in &self.0 {
            f.store(false, Ordering::Relaxed);
        }
        self.0.resize_with(n, || AtomicBool::new(false));
        &self.0
    }
}

impl Clone for TouchFlags {
    /// A work space: a clone starts empty.
    fn clone(&self) -> Self {
        TouchFlags::default()
    }
}

impl std::fmt::Debug for TouchFlags {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "TouchFlags({})", self.0.len())
    }
}

/// How far the particles moved since a list was built, against their skins:
/// of one rank's owned particles or, agreed on (`Parallel::agree`), of all.
/// Particle k moved d_k and was listed with skin s_k (`NeighborList::skins`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Moved {
    /// The largest d_k - s_k / 2 (m).
    pub first: f64,
    /// The sum of the two largest d_k - s_k / 2 (m).
    pub two: f64,
    /// The largest d_k - s_k (m): against the walls.
    pub wall: f64,
}

impl Moved {
    /// Every particle listed with the same skin, d1 >= d2 the two largest displacements.
    pub fn uniform(d1: f64, d2: f64, skin: f64) -> Moved {
        let h = 0.5 * skin;
        Moved { first: d1 - h, two: (d1 - h) + (d2 - h), wall: d1 - skin }
    }

    /// The particle set changed: the list is stale whatever moved.
    pub fn everything() -> Moved {
        Moved { first: f64::INFINITY, two: f64::INFINITY, wall: f64::INFINITY }
    }

    /// True when a list built with skins s_k (`skin` the smallest) may have
    /// missed a contact, walls having moved at most `wall_moved` since. A
    /// pair was listed where its centres were within r_a + r_b + (s_a +
    /// s_b) / 2, so two particles that moved d_a and d_b can touch without
    /// being listed only where (d_a - s_a / 2) + (d_b - s_b / 2) > 0, which
    /// needs the two largest of these to add up to more than zero (not twice
    /// the largest: a few fast particles need not have moved towards each
    /// other); with one skin for all, d1 + d2 > skin. A wall candidate was
    /// listed within r + s of the feature, so the same holds for the largest
    /// d_k - s_k plus `wall_moved`. Radii that grew by at most `grown` since
    /// the build reach that much further: a pair needs 2 `grown` more, a
    /// wall contact `grown`. A margin of 1e-9 of the skin covers the
    /// rounding of the distances. Nothing physical depends on when a list is
    /// rebuilt (history lives only while a contact touches), so this changes
    /// speed only.
    pub fn stale(&self, skin: f64, wall_moved: f64, grown: f64) -> bool {
        let margin = -1e-9 * skin;
        self.two + 2.0 * grown > margin || self.wall + wall_moved + grown > margin
    }
}

/// R*, m* of particle i with a wall (curved: in series with its radius).
fn wall_inertia(wall: &Wall, p: &Particles, i: usize) -> PairInertia {
    match wall.curvature_radius() {
        None => PairInertia::wall(p.radius[i], p.mass[i]),
        Some(rw) => PairInertia::curved_wall(p.radius[i], rw, p.mass[i]),
    }
}

/// The two largest of four values (each pair sorted, largest first; no NaN).
#[inline]
pub(crate) fn top_two(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    if a[0] >= b[0] {
        [a[0], a[1].max(b[0])]
    } else {
        [b[0], b[1].max(a[0])]
    }
}

impl NeighborList {
    pub fn new(skin: f64) -> Self {
        NeighborList { skin, skin_limit: skin, uniform: true, ..Default::default() }
    }

    /// True when the list may have missed a contact (see [`Moved::stale`]),
    /// from this list's own particles' displacements. Also checks that every
    /// particle is finite and inside the domain.
    pub fn needs_rebuild(&self, p: &Particles, domain: &Domain) -> Result<bool, TalusError> {
        Ok(self.displacement(p, domain)?.stale(self.skin, self.wall_moved, self.grown))
    }

    /// How far the owned particles moved since the last build against their
    /// skins ([`Moved`]; infinite if the particle set changed); checks that
    /// each is finite and in the domain.
    pub fn displacement(&self, p: &Particles, domain: &Domain) -> Result<Moved, TalusError> {
        let n = p.owned();
        let changed = self.x_ref.len() != n;
        // with skins of their own, d_k - s_k / 2 (the two largest) and d_k - s_k
        // (the largest); else the squared displacements (the two largest)
        let own = !self.uniform && self.skins.len() >= n;
        // the two largest of these of particles `range`, the largest d_k - s_k,
        // and the first of them outside the domain (a maximum is exact in any
        // order). One branch-light pass: a value goes into the top two only
        // where it beats the second (the same two either way), and the domain
        // test is or-ed up and looked into again only where some particle fails
        // it (a NaN fails it too).
        let (lo, hi) = (domain.lo, domain.hi);
        let outside = |x: &Vec3| {
            !(x.x >= lo.x) | !(x.y >= lo.y) | !(x.z >= lo.z) | !(x.x <= hi.x) | !(x.y <= hi.y) | !(x.z <= hi.z)
        };
        let none = if own { f64::NEG_INFINITY } else { 0.0 };
        let part = |range: std::ops::Range<usize>| -> ([f64; 2], f64, Option<usize>) {
            let mut top = [none; 2];
            let mut wall = f64::NEG_INFINITY;
            let mut bad = false;
            let pos = &p.pos[range.clone()];
            if changed {
                bad = pos.iter().fold(false, |b, x| b | outside(x));
            } else if own {
                for (i, x) in range.clone().zip(pos) {
                    let at = if p.image.is_empty() { *x } else { p.list_pos(i, &self.period) };
                    let (d, s) = ((at - self.x_ref[i]).norm(), self.skins[i]);
                    let e = d - 0.5 * s;
                    if e > top[1] {
                        top = top_two(top, [e, f64::NEG_INFINITY]);
                    }
                    wall = wall.max(d - s);
                    bad |= outside(x);
                }
            } else if p.image.is_empty() {
                for (x, r) in pos.iter().zip(&self.x_ref[range.clone()]) {
                    let d2 = (x - r).norm_squared();
                    if d2 > top[1] {
                        top = top_two(top, [d2, 0.0]);
                    }
                    bad |= outside(x);
                }
            } else {
                for (i, x) in range.clone().zip(pos) {
                    let d2 = (p.list_pos(i, &self.period) - self.x_ref[i]).norm_squared();
                    if d2 > top[1] {
                        top = top_two(top, [d2, 0.0]);
                    }
                    bad |= outside(x);
                }
            }
            (top, wall, if bad { range.clone().find(|&i| outside(&p.pos[i])) } else { None })
        };
        let (top, wall, bad) = if !self.threaded || n <= 2 * PASS_BLOCK {
            part(0..n)
        } else {
            blocks(n, PASS_BLOCK)
                .map(part)
                .reduce(|| ([none; 2], f64::NEG_INFINITY, None), |x, y| (top_two(x.0, y.0), x.1.max(y.1), x.2.or(y.2)))
        };
        if let Some(i) = bad {
            return Err(particle_error(p, i, domain));
        }
        Ok(if changed {
            Moved::everything()
        } else if own {
            Moved { first: top[0], two: top[0] + top[1], wall }
        } else {
            // (fewer than two particles: the zeros the top two started from
            // are no particle's, and under MPI must not outweigh another
            // rank's values below zero)
            let mut m = Moved::uniform(top[0].sqrt(), top[1].sqrt(), self.skin);
            if n < 2 {
                m.two = f64::NEG_INFINITY;
            }
            if n == 0 {
                (m.first, m.wall) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
            }
            m
        })
    }

    /// The non-zero contact history keyed by global ids, sorted by key.
    pub fn take_history(&self, p: &Particles) -> History {
        self.history_of(&p.id, false)
    }

    /// The non-zero contact history keyed by the ids `ids` of the list's
    /// particles (in storage order), sorted by key.
    fn history_of(&self, ids: &[u64], threaded: bool) -> History {
        self.history_in_id_order(ids, threaded).unwrap_or_else(|| self.history_sorted(ids))
    }

    /// As [`NeighborList::take_history`], read row by row in order of the
    /// particles' ids, so that it comes out sorted (a row holds its particle's
    /// pairs as the lower id, in order of partner id): one pass, on the
    /// caller's pool's threads where `threaded` (blocks of particles joined in
    /// order: the same entries). `None` where an id can be held twice (a
    /// periodic image) or the list is not of these particles (`ids`: the
    /// particles' ids in storage order).
    pub fn history_in_id_order(&self, ids: &[u64], threaded: bool) -> Option<History> {
        if self.row_start.len() != ids.len() + 1 || self.wall_start.len() > ids.len() + 1 {
            return None;
        }
        let order = IdIndex::new(ids).into_order()?;
        let threaded = threaded && order.len() > 2 * ROW_BLOCK;
        let pair_rows = |range: std::ops::Range<usize>, out: &mut Vec<((u64, u64), Hist)>| {
            for &a in &order[range] {
                let a = a as usize;
                for k in self.row_start[a] as usize..self.row_start[a + 1] as usize {
                    let e = self.pair_entry(k);
                    if !e.is_zero() {
                        out.push(((ids[a], ids[self.pairs[k].1 as usize]), e));
                    }
                }
            }
        };
        let with_walls = self.wall_start.len().saturating_sub(1);
        let wall_rows = |range: std::ops::Range<usize>, out: &mut Vec<((u64, u16, u32), Hist)>| {
            for &i in &order[range] {
                let i = i as usize;
                if i >= with_walls {
                    continue;
                }
                for k in self.wall_start[i] as usize..self.wall_start[i + 1] as usize {
                    let e = self.wall_entry(k);
                    if !e.is_zero() {
                        let (w, f) = self.wall_feat[k];
                        out.push(((ids[i], w, f), e));
                    }
                }
            }
        };
        let mut h = History {
            pairs: in_blocks(order.len(), threaded, pair_rows),
            walls: in_blocks(order.len(), threaded, wall_rows),
        };
        // in order already (a wall's candidates come in the order its search
        // gives them): each is one pass that finds it so
        sort_by_key_runs(&mut h.pairs, |k| k.0);
        sort_by_key_runs(&mut h.walls, |k| k.0);
        Some(h)
    }

    /// [`NeighborList::history_of`] in list order, then sorted.
    fn history_sorted(&self, ids: &[u64]) -> History {
        let mut h = History::default();
        for (k, &(a, b)) in self.pairs.iter().enumerate() {
            let e = self.pair_entry(k);
            if !e.is_zero() {
                h.pairs.push(((ids[a as usize], ids[b as usize]), e));
            }
        }
        sort_by_key_runs(&mut h.pairs, |k| k.0);
        for i in 0..self.wall_start.len().saturating_sub(1).min(ids.len()) {
            for k in self.wall_start[i] as usize..self.wall_start[i + 1] as usize {
                let e = self.wall_entry(k);
                if !e.is_zero() {
                    let (w, f) = self.wall_feat[k];
                    h.walls.push(((ids[i], w, f), e));
                }
            }
        }
        sort_by_key_runs(&mut h.walls, |k| k.0);
        h
    }

    /// Pair k's history (shear and rolling).
    #[inline]
    pub fn pair_entry(&self, k: usize) -> Hist {
        Hist::at(&self.pair_hist, &self.pair_roll, k)
    }

    /// Wall candidate k's history (shear and rolling).
    #[inline]
    pub fn wall_entry(&self, k: usize) -> Hist {
        Hist::at(&self.wall_hist, &self.wall_roll, k)
    }

    /// Rebuild the lists, carrying contact history over by global ids.
    pub fn build(&mut self, p: &Particles, walls: &[Wall]) {
        let h = self.take_history(p);
        self.build_with(p, walls, Carry::Keyed(&h));
    }

    /// Rebuild the lists from particle positions, taking contact history from
    /// `carry`. Pairs: every pair within reach of which at least one particle
    /// is owned (ghosts are the particles after `p.owned()`); wall candidates:
    /// owned particles only.
    pub fn build_with(&mut self, p: &Particles, walls: &[Wall], carry: Carry) {
        self.set_skins(p);
        let grid = CellGrid::new(p, self.skin, &self.skins, self.uniform, &self.period, self.threaded && p.len() > 2 * ROW_BLOCK);
        // the last build's rows are read pair by pair where they are of the
        // same particles in the same places (no periodic images)
        let read;
        let nothing = History::default();
        let (hist, mapped) = match carry {
            Carry::Keyed(h) => (Some(h), None),
            Carry::Own if self.ids == p.id && p.image.is_empty() => (None, None),
            Carry::Own | Carry::OwnAnd(_) => {
                let arrived = if let Carry::OwnAnd(h) = carry { h } else { &nothing };
                match self.old_places(p) {
                    Some(map) => (None, Some((map, arrived))),
                    None => {
                        let mut keyed = self.history_of(&self.ids, self.threaded);
                        keyed.merge(arrived.clone());
                        read = keyed;
                        (Some(&read), None)
                    }
                }
            }
        };
        let mapped = mapped.as_ref().map(|(map, arrived)| (&map[..], *arrived));
        self.build_pairs(p, &grid, hist.map(|h| &h.pairs[..]), mapped);
        self.build_incident(p);
        self.build_wall_candidates(p, walls, hist.map(|h| &h.walls[..]), mapped);
        self.ids.clear();
        self.ids.extend_from_slice(&p.id);
        self.x_ref.clear();
        if self.threaded {
            self.x_ref.par_extend((0..p.owned()).into_par_iter().with_min_len(PASS_BLOCK).map(|i| p.list_pos(i, &self.period)));
        } else {
            self.x_ref.extend((0..p.owned()).map(|i| p.list_pos(i, &self.period)));
        }
        self.wall_moved = 0.0;
        self.grown = 0.0;
        self.builds += 1;
    }

    /// The particles' radii and masses changed since the build, no radius
    /// by more than `grown` (m) up (`Simulation::set_radii`; one rank, no
    /// ghosts): the list is kept, and holds every pair and wall contact that
    /// can touch until [`Moved::stale`] says otherwise, counting `grown`; the
    /// wall candidates' R*, m* and the law's constants are made again from
    /// the new radii and masses, as a build would make them. The pairs that
    /// touch, their history and every result are then those of a new list.
    pub fn radii_changed(&mut self, p: &Particles, walls: &[Wall], grown: f64) {
        self.grown += grown.max(0.0);
        for i in 0..p.owned().min(self.wall_start.len().saturating_sub(1)) {
            for k in self.wall_start[i] as usize..self.wall_start[i + 1] as usize {
                self.wall_inertia[k] = wall_inertia(&walls[self.wall_feat[k].0 as usize], p, i);
            }
        }
        self.law_constants.forget();
    }

    /// Each particle's skin for this build (`skins`, `uniform`): the case's
    /// skin, or where a [`SkinRule`] is set (not in a periodic domain), the
    /// rule's of the particle's speed, at most `skin_limit`. A ghost gets
    /// the skin its owner gives it (the same velocity, the same rule).
    fn set_skins(&mut self, p: &Particles) {
        let rule = if self.period == Vec3::zeros() { self.skin_rule } else { SkinRule::default() };
        let (skin, limit) = (self.skin, self.skin_limit);
        self.skins.clear();
        if rule.per_speed == 0.0 {
            self.skins.resize(p.len(), skin);
            self.uniform = true;
            return;
        }
        let of = |v: &Vec3| rule.of(skin, limit, v.norm());
        if self.threaded {
            self.skins.par_extend(p.vel.par_iter().with_min_len(PASS_BLOCK).map(of));
        } else {
            self.skins.extend(p.vel.iter().map(of));
        }
        self.uniform = self.skins.iter().all(|&s| s == skin);
    }

    /// Each particle's place at the last build (`u32::MAX`: it was not on
    /// this rank then), found by its id; `None` where an id is held twice,
    /// now or then (periodic images), or the last build's arrays are not of
    /// its particles.
    fn old_places(&self, p: &Particles) -> Option<Vec<u32>> {
        if !p.image.is_empty() || self.row_start.len() != self.ids.len() + 1 || self.wall_start.len() > self.ids.len() + 1 {
            return None;
        }
        let index = IdIndex::new(&self.ids);
        if index.twice {
            return None;
        }
        let place = |&id: &u64| index.get(id).map_or(u32::MAX, |i| i as u32);
        Some(if self.threaded { p.id.par_iter().with_min_len(PASS_BLOCK).map(place).collect() } else { p.id.iter().map(place).collect() })
    }

    /// The pairs within reach (`id_a < id_b`, sorted), each with its history
    /// from `old_pair` (sorted by ids) and its R*, m*. Each pair is found once
    /// (`CellGrid::search`, a half stencil), then given to the row of its
    /// lower id (a counting sort by that particle), and each row is sorted by
    /// partner id. Each pair found is one pair of the list, so the counting
    /// sort's row starts are the list's, and the rows are written in place. On
    /// several threads, blocks of the grid are searched at once and blocks of
    /// rows are made at once, each into its own part of the arrays: the same
    /// list as on one.
    fn build_pairs(&mut self, p: &Particles, grid: &CellGrid, old_pair: Option<&[((u64, u64), Hist)]>, mapped: Option<(&[u32], &History)>) {
        let n = p.len();
        let rolling = self.rolling_history;
        let threaded = self.threaded && n > 2 * ROW_BLOCK;
        // every pair within reach once, as (row owner, partner)
        // (then the wide particles' pairs beyond the cells' range)
        let wide = grid.wide.len();
        let found: Vec<Vec<(u32, u32)>> = if threaded {
            let mut found: Vec<Vec<(u32, u32)>> = blocks(n, ROW_BLOCK)
                .map(|range| {
                    let mut f = Vec::new();
                    grid.search(p, range, &mut f);
                    f
                })
                .collect();
            found.par_extend(blocks(wide, WIDE_BLOCK).map(|range| {
                let mut f = Vec::new();
                grid.search_wide(p, range, &mut f);
                f
            }));
            found
        } else {
            let mut f = std::mem::take(&mut self.found);
            f.clear();
            grid.search(p, 0..n, &mut f);
            grid.search_wide(p, 0..wide, &mut f);
            vec![f]
        };
        // counting sort by row owner: `keyed[seg[a]..seg[a + 1]]` holds a's
        // partners as (partner id, partner), sorted within each row later;
        // one list pair per pair found, so these are the list's row starts
        let mut seg = std::mem::take(&mut self.spare.row_start);
        let mut keyed = std::mem::take(&mut self.row_keyed);
        {
            let chunks: Vec<&[(u32, u32)]> = found.iter().map(|f| &f[..]).collect();
            let partner = |_: usize, &(_, b): &(u32, u32)| (p.id[b as usize], b);
            counting_sort(&chunks, n, |&(a, _)| Some(a as usize), partner, (0, 0), &mut seg, &mut keyed, threaded);
        }
        // (on several threads the pairs found are not kept past here: peak
        // memory; one thread keeps its buffer for the next build)
        if !threaded {
            self.found = found.into_iter().next().unwrap_or_default();
        } else {
            drop(found);
        }
        // one list pair per pair found: particle a's row is `seg[a]..seg[a + 1]`
        // of every array, written in place (by blocks of rows on several threads)
        let total = seg[n] as usize;
        // written into the spare arrays: the last build's are read for history
        let mut pairs = std::mem::take(&mut self.spare.pairs);
        let mut hist = std::mem::take(&mut self.spare.hist);
        let mut roll = std::mem::take(&mut self.spare.roll);
        // every place is written below: only a longer list's new places are filled first
        sized(&mut pairs, total, (0, 0));
        sized(&mut hist, total, Vec3::zeros());
        sized(&mut roll, if rolling { total } else { 0 }, Vec3::zeros());
        let first;
        let old = match (old_pair, mapped) {
            (Some(pairs), _) => {
                first = history_runs(p, pairs);
                OldPairs::Keyed { pairs, first: &first }
            }
            (None, Some((map, arrived))) => OldPairs::Mapped {
                map,
                old_ids: &self.ids,
                start: &self.row_start,
                pairs: &self.pairs,
                hist: &self.pair_hist,
                roll: &self.pair_roll,
                arrived: &arrived.pairs,
            },
            (None, None) => OldPairs::Rows { start: &self.row_start, pairs: &self.pairs, hist: &self.pair_hist, roll: &self.pair_roll },
        };
        if !threaded {
            let mut rows = Rows { pairs: &mut pairs, hist: &mut hist, roll: &mut roll };
            rows.make(p, &seg, &mut keyed, &old, 0..n);
        } else {
            let seg = &seg;
            let roll_blocks = if rolling { row_blocks(&mut roll, seg, n) } else { Vec::new() };
            let mut roll_blocks = roll_blocks.into_iter();
            let blocks: Vec<_> = row_blocks(&mut keyed, seg, n)
                .into_iter()
                .zip(row_blocks(&mut pairs, seg, n))
                .zip(row_blocks(&mut hist, seg, n))
                .map(|(((range, keyed), (_, pairs)), (_, hist))| {
                    let roll: &mut [Vec3] = roll_blocks.next().map_or(&mut [], |x| x.1);
                    (range, keyed, Rows { pairs, hist, roll })
                })
                .collect();
            blocks.into_par_iter().for_each(|(range, keyed, mut rows)| rows.make(p, seg, keyed, &old, range));
        }
        // the last build's arrays are the next one's spare ones
        self.spare.pairs = std::mem::replace(&mut self.pairs, pairs);
        self.spare.hist = std::mem::replace(&mut self.pair_hist, hist);
        self.spare.roll = std::mem::replace(&mut self.pair_roll, roll);
        self.spare.row_start = std::mem::replace(&mut self.row_start, seg);
        self.row_keyed = keyed;
    }

    /// The pairs in which each owned particle is the higher id, each
    /// particle's in order of partner id (`incident`): a counting sort by
    /// particle of the rows taken in order of their particles' ids, so each
    /// particle's pairs come in order of partner id with no sort; where an id
    /// is held twice (periodic images), a counting sort of the list, then a
    /// sort within each particle's pairs.
    fn build_incident(&mut self, p: &Particles) {
        let threaded = self.threaded && p.owned() > 2 * ROW_BLOCK;
        match IdIndex::new(&p.id).into_order() {
            Some(order) => self.incident_by_rows(p, &order, threaded),
            None => self.incident_sorted(p, threaded),
        }
        // a new list starts with no pair touching
        fill_with(&mut self.pair_slot, self.pairs.len(), crate::forces::zero_slot(&self.pairs), threaded);
        sized(&mut self.pair_out, self.pairs.len() + 1, PairOut::default());
        self.pair_out[self.pairs.len()] = PairOut::default();
    }

    /// `incident` from the rows in order of their particles' ids (`order`:
    /// the places in order of id), as `counting_sort` does it: on threads,
    /// each counts, then writes, the pairs of the rows of its own run of
    /// `order` (a range of ids: the counts read the rows in storage order,
    /// skipping the others' rows).
    fn incident_by_rows(&mut self, p: &Particles, order: &[u32], threaded: bool) {
        let n_own = p.owned();
        let (pairs, rows) = (&self.pairs, &self.row_start);
        let parts = if threaded { rayon::current_num_threads().clamp(1, order.len().max(1)) } else { 1 };
        let per = order.len().div_ceil(parts).max(1);
        let runs: Vec<&[u32]> = order.chunks(per).collect();
        // the rows of ids from `lo` up to (not including) `hi`, counted by the higher id's particle
        let count = |lo: u64, hi: u64| {
            let mut counts = vec![0u32; n_own];
            for (a, &id) in p.id.iter().enumerate() {
                if (lo..hi).contains(&id) {
                    for &(_, b) in &pairs[rows[a] as usize..rows[a + 1] as usize] {
                        if let Some(c) = counts.get_mut(b as usize) {
                            *c += 1;
                        }
                    }
                }
            }
            counts
        };
        // the pairs of the rows of `run` into their places (`fill`: each particle's next)
        let scatter = |run: &[u32], fill: &mut [u32], put: &mut dyn FnMut(usize, u32)| {
            for &a in run {
                let a = a as usize;
                for k in rows[a] as usize..rows[a + 1] as usize {
                    if let Some(f) = fill.get_mut(pairs[k].1 as usize) {
                        put(*f as usize, k as u32);
                        *f += 1;
                    }
                }
            }
        };
        if runs.len() <= 1 {
            // one thread: the counts read the list in order
            let start = &mut self.incident_start;
            key_starts(start, n_own, pairs.iter().map(|&(_, b)| b as usize));
            sized(&mut self.incident, start[n_own] as usize, 0);
            let mut fill = start[..n_own].to_vec();
            let out = &mut self.incident;
            scatter(order, &mut fill, &mut |i, k| out[i] = k);
            return;
        }
        let mut fill: Vec<Vec<u32>> = {
            let first_id = |r: &[u32]| p.id[r[0] as usize];
            let bounds: Vec<(u64, u64)> =
                (0..runs.len()).map(|t| (if t == 0 { 0 } else { first_id(runs[t]) }, runs.get(t + 1).map_or(u64::MAX, |r| first_id(r)))).collect();
            bounds.par_iter().map(|&(lo, hi)| count(lo, hi)).collect()
        };
        run_places(&mut fill, &mut self.incident_start, n_own);
        sized(&mut self.incident, self.incident_start[n_own] as usize, 0);
        let places = Places::of(&mut self.incident);
        runs.par_iter().zip(fill.par_iter_mut()).for_each(|(run, fill)| scatter(run, fill, &mut |i, k| places.put(i, k)));
    }

    /// `incident` by a counting sort of the list, then a sort of each
    /// particle's pairs by partner id (ids held twice).
    fn incident_sorted(&mut self, p: &Particles, threaded: bool) {
        let n_own = p.owned();
        // (partner id, pair), so that sorting needs no lookups
        let (start, keyed) = (&mut self.incident_start, &mut self.incident_keyed);
        let own = |&(_, b): &(u32, u32)| ((b as usize) < n_own).then_some(b as usize);
        let partner = |k: usize, &(a, _): &(u32, u32)| (p.id[a as usize], k as u32);
        counting_sort(&[&self.pairs], n_own, own, partner, (0, 0), start, keyed, threaded);
        let start = &*start;
        let sort_rows = |keyed: &mut [(u64, u32)], range: std::ops::Range<usize>, off: usize| {
            for i in range {
                let seg = &mut keyed[start[i] as usize - off..start[i + 1] as usize - off];
                if !seg.windows(2).all(|w| w[0].0 < w[1].0) {
                    seg.sort_unstable();
                }
            }
        };
        if !threaded {
            sort_rows(keyed, 0..n_own, 0);
        } else {
            row_blocks(keyed, start, n_own).into_par_iter().for_each(|(range, part)| {
                let off = start[range.start] as usize;
                sort_rows(part, range, off)
            });
        }
        self.incident.clear();
        room(&mut self.incident, keyed.len());
        if threaded {
            self.incident.par_extend(keyed.par_iter().map(|x| x.1));
        } else {
            self.incident.extend(keyed.iter().map(|x| x.1));
        }
    }

    /// Every owned particle's wall candidates `(wall, feature)` within reach,
    /// each with its history from `old_wall` (sorted by key) and its R*, m*.
    /// On several threads, blocks of particles at once, joined in order: the
    /// same candidates as on one.
    fn build_wall_candidates(
        &mut self,
        p: &Particles,
        walls: &[Wall],
        old_wall: Option<&[((u64, u16, u32), Hist)]>,
        mapped: Option<(&[u32], &History)>,
    ) {
        let n_own = p.owned();
        // written into the spare arrays: the last build's are read for history
        let mut all = WallRows {
            start: std::mem::take(&mut self.spare.wall_start),
            feat: std::mem::take(&mut self.spare.wall_feat),
            hist: std::mem::take(&mut self.spare.wall_hist),
            roll: std::mem::take(&mut self.spare.wall_roll),
            inertia: std::mem::take(&mut self.wall_inertia),
            owners: std::mem::take(&mut self.wall_owners),
            image: std::mem::take(&mut self.wall_image),
        };
        all.clear();
        let rows = WallRowsThen { start: &self.wall_start, feat: &self.wall_feat, hist: &self.wall_hist, roll: &self.wall_roll };
        let old = match (old_wall, mapped) {
            (Some(keyed), _) => OldWalls::Keyed(keyed),
            (None, Some((map, arrived))) => OldWalls::Mapped { map, rows, arrived: &arrived.walls },
            (None, None) => OldWalls::Rows(rows),
        };
        let find = WallFind { p, walls, old, skins: &self.skins, period: self.period, rolling: self.rolling_history };
        if !self.threaded || n_own <= 2 * ROW_BLOCK {
            find.append(&mut all, 0..n_own);
        } else {
            let parts: Vec<WallRows> = blocks(n_own, ROW_BLOCK)
                .map(|range| {
                    let mut r = WallRows::default();
                    find.append(&mut r, range);
                    r
                })
                .collect();
            // the blocks' rows end to end (the large arrays copied on the threads)
            let mut base = 0;
            for b in &parts {
                all.start.extend(b.start.iter().map(|s| s + base));
                base += b.feat.len() as u32;
            }
            joined(&mut all.feat, parts.iter().map(|b| &b.feat[..]));
            joined(&mut all.hist, parts.iter().map(|b| &b.hist[..]));
            joined(&mut all.roll, parts.iter().map(|b| &b.roll[..]));
            joined(&mut all.inertia, parts.iter().map(|b| &b.inertia[..]));
            joined(&mut all.owners, parts.iter().map(|b| &b.owners[..]));
            joined(&mut all.image, parts.iter().map(|b| &b.image[..]));
        }
        all.start.push(all.feat.len() as u32);
        // the last build's arrays are the next one's spare ones
        self.spare.wall_start = std::mem::replace(&mut self.wall_start, all.start);
        self.spare.wall_feat = std::mem::replace(&mut self.wall_feat, all.feat);
        self.spare.wall_hist = std::mem::replace(&mut self.wall_hist, all.hist);
        self.spare.wall_roll = std::mem::replace(&mut self.wall_roll, all.roll);
        self.wall_inertia = all.inertia;
        self.wall_owners = all.owners;
        self.wall_image = all.image;
    }
}

/// The wall candidates of a range of particles (as the `NeighborList`
/// fields of the same names; `start` relative to the range's first
/// candidate and without the closing entry).
#[derive(Default)]
struct WallRows {
    start: Vec<u32>,
    feat: Vec<(u16, u32)>,
    hist: Vec<Vec3>,
    roll: Vec<Vec3>,
    inertia: Vec<PairInertia>,
    owners: Vec<u32>,
    image: Vec<[i32; 3]>,
}

impl WallRows {
    fn clear(&mut self) {
        self.start.clear();
        self.feat.clear();
        self.hist.clear();
        self.roll.clear();
        self.inertia.clear();
        self.owners.clear();
        self.image.clear();
    }
}

/// What finding wall candidates reads.
struct WallFind<'a> {
    p: &'a Particles,
    walls: &'a [Wall],
    old: OldWalls<'a>,
    /// Each particle's skin (`NeighborList::skins`).
    skins: &'a [f64],
    period: Vec3,
    rolling: bool,
}

impl WallFind<'_> {
    /// Append the candidates of the owned particles `range` to `out`.
    fn append(&self, out: &mut WallRows, range: std::ops::Range<usize>) {
        let p = self.p;
        let base = out.feat.len();
        let mut feats = Vec::new();
        // in a periodic domain a wall also meets the particles' images (a
        // plane, parallel to every periodic axis, meets each particle once)
        let periodic = self.period != Vec3::zeros();
        let shifts = crate::parallel::image_shifts(&self.period);
        // a small mesh's triangles near each block of particles (which lie
        // close together in storage order), by (wall, shift): each particle
        // tests only those, the same candidates as testing every triangle
        let mut near: Vec<(bool, Vec<u32>)> = vec![(false, Vec::new()); self.walls.len() * shifts.len()];
        for i in range.clone() {
            if (i - range.start).is_multiple_of(WALL_BLOCK) {
                let block = i..(i + WALL_BLOCK).min(range.end);
                let far = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
                let (lo, hi) = p.pos[block.clone()].iter().fold(far, |(lo, hi), x| (lo.inf(x), hi.sup(x)));
                let r = p.radius[block.clone()].iter().cloned().fold(0.0, f64::max);
                let skin = self.skins[block].iter().cloned().fold(0.0, f64::max);
                for (w, wall) in self.walls.iter().enumerate() {
                    for (k, g) in shifts.iter().enumerate() {
                        let s = crate::particles::image_shift(g, &self.period);
                        let (is, list) = &mut near[w * shifts.len() + k];
                        *is = wall.active && wall.near_box(&(lo + s), &(hi + s), r, skin, list);
                    }
                }
            }
            out.start.push((out.feat.len() - base) as u32);
            let before = out.feat.len();
            for (w, wall) in self.walls.iter().enumerate() {
                if !wall.active {
                    continue;
                }
                for (k, g) in shifts.iter().enumerate() {
                    if *g != [0; 3] && matches!(wall.shape, crate::walls::Shape::Plane(_)) {
                        continue;
                    }
                    feats.clear();
                    let x = p.pos[i] + crate::particles::image_shift(g, &self.period);
                    let (is, list) = &near[w * shifts.len() + k];
                    wall.candidates_in(&x, p.radius[i], self.skins[i], is.then_some(&list[..]), &mut feats);
                    if feats.is_empty() {
                        continue;
                    }
                    if periodic {
                        out.image.extend(std::iter::repeat(*g).take(feats.len()));
                    }
                    let pi = wall_inertia(wall, p, i);
                    for &f in &feats {
                        out.inertia.push(pi);
                        out.feat.push((w as u16, f));
                        let h = self.old.find(p.id[i], i, w as u16, f);
                        out.hist.push(h.shear);
                        if self.rolling {
                            out.roll.push(h.roll);
                        }
                    }
                }
            }
            if out.feat.len() > before {
                out.owners.push(i as u32);
            }
        }
    }
}

/// The wall history of the last build, where a new candidate finds its own.
enum OldWalls<'a> {
    /// Keyed by (id, wall, feature) and sorted.
    Keyed(&'a [((u64, u16, u32), Hist)]),
    /// The last build's candidates, of the same particles in the same places.
    Rows(WallRowsThen<'a>),
    /// The last build's candidates at each particle's place then (`map`,
    /// `u32::MAX` for none), else those received (`Carry::OwnAnd`).
    Mapped { map: &'a [u32], rows: WallRowsThen<'a>, arrived: &'a [((u64, u16, u32), Hist)] },
}

/// The last build's wall candidates (as the `NeighborList` fields of the same names).
struct WallRowsThen<'a> {
    start: &'a [u32],
    feat: &'a [(u16, u32)],
    hist: &'a [Vec3],
    roll: &'a [Vec3],
}

impl WallRowsThen<'_> {
    /// The history of the contact of the particle at place i then with
    /// feature `f` of wall `w`: zero where there is none.
    #[inline(always)]
    fn find(&self, i: usize, w: u16, f: u32) -> Hist {
        if i + 1 >= self.start.len() {
            return Hist::ZERO;
        }
        let places = self.start[i] as usize..self.start[i + 1] as usize;
        match self.feat[places.clone()].iter().position(|&x| x == (w, f)) {
            Some(j) => Hist::kept_at(self.hist, self.roll, places.start + j),
            None => Hist::ZERO,
        }
    }
}

impl OldWalls<'_> {
    /// The history of particle i's (of id `id`) contact with feature `f` of
    /// wall `w`: zero where there is none.
    #[inline(always)]
    fn find(&self, id: u64, i: usize, w: u16, f: u32) -> Hist {
        let keyed = |old: &[((u64, u16, u32), Hist)]| old.binary_search_by_key(&(id, w, f), |x| x.0).map(|k| old[k].1).unwrap_or(Hist::ZERO);
        match self {
            OldWalls::Keyed(old) => keyed(old),
            OldWalls::Rows(rows) => rows.find(i, w, f),
            OldWalls::Mapped { map, rows, arrived } => {
                let h = if map[i] == u32::MAX { Hist::ZERO } else { rows.find(map[i] as usize, w, f) };
                if h.is_zero() && !arrived.is_empty() {
                    keyed(arrived)
                } else {
                    h
                }
            }
        }
    }
}

/// Sort `v` by key, where it comes as runs already in order of key (a list's
/// rows, each in order of partner id; `particle` names the particle whose
/// entry a key is): the runs, each one particle's, are put in order of their
/// first keys and laid end to end, which is the sorted order unless two runs
/// overlap (an id held twice, by a particle and its periodic image), and then
/// `v` is sorted whole. Either way the result is `v` sorted by key, and each
/// entry is moved once. Measured against a whole sort on H1-paper's discharge
/// (250,000 history entries of 64 bytes; 2,000 steps, one thread): the
/// migration stage, where the sort is, fell from 8.9 to 6.2 s.
pub fn sort_by_key_runs<K: Ord + Copy, V: Copy>(v: &mut Vec<(K, V)>, particle: impl Fn(&K) -> u64) {
    if v.windows(2).all(|w| w[0].0 <= w[1].0) {
        return;
    }
    // (first key, start, end) of each run: one particle's entries in order
    let mut runs: Vec<(K, u32, u32)> = Vec::new();
    let mut start = 0;
    for i in 1..=v.len() {
        if i == v.len() || v[i].0 < v[i - 1].0 || particle(&v[i].0) != particle(&v[i - 1].0) {
            runs.push((v[start].0, start as u32, i as u32));
            start = i;
        }
    }
    runs.sort_unstable_by_key(|r| r.0);
    let mut out = Vec::with_capacity(v.len());
    for &(_, s, e) in &runs {
        out.extend_from_slice(&v[s as usize..e as usize]);
    }
    if !out.windows(2).all(|w| w[0].0 <= w[1].0) {
        out.sort_unstable_by_key(|x| x.0);
    }
    *v = out;
}

/// The contact history of the last build, where a new row's pairs find theirs.
enum OldPairs<'a> {
    /// Keyed by ids and sorted, and where each particle's run of it starts
    /// (`first[a]`: the first entry whose lower id is particle a's; the end of
    /// the history if there is none).
    Keyed { pairs: &'a [((u64, u64), Hist)], first: &'a [u32] },
    /// The last build's rows, of the same particles in the same places.
    Rows { start: &'a [u32], pairs: &'a [(u32, u32)], hist: &'a [Vec3], roll: &'a [Vec3] },
    /// The last build's rows, each particle's at its place then (`map`,
    /// `u32::MAX` for none; `old_ids`: the ids then), and where a pair has
    /// no history there, the history received (`Carry::OwnAnd`).
    Mapped {
        map: &'a [u32],
        old_ids: &'a [u64],
        start: &'a [u32],
        pairs: &'a [(u32, u32)],
        hist: &'a [Vec3],
        roll: &'a [Vec3],
        arrived: &'a [((u64, u64), Hist)],
    },
}

/// Where a row's look-ups have got to in the old history (`OldPairs::find`):
/// places `k..end` of the old rows or keyed history, and for
/// `OldPairs::Mapped` places `ak..a_end` of the history received.
struct Cursor {
    k: usize,
    end: usize,
    ak: usize,
    a_end: usize,
}

impl OldPairs<'_> {
    /// Particle a's (of id `ida`) old pairs: where its row's look-ups start.
    #[inline(always)]
    fn run(&self, a: usize, ida: u64) -> Cursor {
        match self {
            OldPairs::Keyed { pairs, first } => Cursor { k: first[a] as usize, end: pairs.len(), ak: 0, a_end: 0 },
            OldPairs::Rows { start, .. } => Cursor { k: start[a] as usize, end: start[a + 1] as usize, ak: 0, a_end: 0 },
            OldPairs::Mapped { map, start, arrived, .. } => {
                let (k, end) = match map[a] {
                    u32::MAX => (0, 0),
                    o => (start[o as usize] as usize, start[o as usize + 1] as usize),
                };
                let (ak, a_end) = if arrived.is_empty() {
                    (0, 0)
                } else {
                    (arrived.partition_point(|e| e.0 .0 < ida), arrived.partition_point(|e| e.0 .0 <= ida))
                };
                Cursor { k, end, ak, a_end }
            }
        }
    }

    /// The history of the pair of particle ids (ida, idb), looked for from
    /// the cursor on (a row's pairs come in order of partner id, so the
    /// cursor only moves on): zero where there is none.
    #[inline(always)]
    fn find(&self, ids: &[u64], c: &mut Cursor, ida: u64, idb: u64) -> Hist {
        /// The old row's entry of partner `idb` (partners' ids `ids`), from `c.k` on.
        #[inline(always)]
        fn in_row(ids: &[u64], pairs: &[(u32, u32)], hist: &[Vec3], roll: &[Vec3], c: &mut Cursor, idb: u64) -> Hist {
            while c.k < c.end && ids[pairs[c.k].1 as usize] < idb {
                c.k += 1;
            }
            if c.k < c.end && ids[pairs[c.k].1 as usize] == idb {
                Hist::kept_at(hist, roll, c.k)
            } else {
                Hist::ZERO
            }
        }
        match self {
            OldPairs::Keyed { pairs, .. } => {
                let key = (ida, idb);
                while c.k < c.end && pairs[c.k].0 < key {
                    c.k += 1;
                }
                if c.k < c.end && pairs[c.k].0 == key {
                    pairs[c.k].1
                } else {
                    Hist::ZERO
                }
            }
            OldPairs::Rows { pairs, hist, roll, .. } => in_row(ids, pairs, hist, roll, c, idb),
            OldPairs::Mapped { old_ids, pairs, hist, roll, arrived, .. } => {
                let h = in_row(old_ids, pairs, hist, roll, c, idb);
                if !h.is_zero() || c.ak == c.a_end {
                    return h;
                }
                while c.ak < c.a_end && arrived[c.ak].0 .1 < idb {
                    c.ak += 1;
                }
                if c.ak < c.a_end && arrived[c.ak].0 .1 == idb {
                    arrived[c.ak].1
                } else {
                    Hist::ZERO
                }
            }
        }
    }
}

/// Where each particle's run of the sorted history starts (`OldPairs::first`),
/// by one pass over the history, each run's particle looked up by id
/// ([`IdIndex`]). Looking each particle up in the history instead (a binary
/// search per particle, in storage order) misses the cache at every step of
/// every search.
fn history_runs(p: &Particles, old_pair: &[((u64, u64), Hist)]) -> Vec<u32> {
    let n = p.len();
    let end = old_pair.len() as u32;
    // a particle without a run starts at the end: it finds no history
    let mut first = vec![end; n];
    if old_pair.is_empty() {
        return first;
    }
    let index = IdIndex::new(&p.id);
    let mut k = 0;
    while k < old_pair.len() {
        let ida = old_pair[k].0 .0;
        if let Some(a) = index.get(ida) {
            first[a] = k as u32;
        }
        while k < old_pair.len() && old_pair[k].0 .0 == ida {
            k += 1;
        }
    }
    // in a periodic domain an id can be held twice (a particle and its
    // image): every copy starts at the run found for the id
    if index.twice {
        for i in 0..n {
            if let Some(r) = index.get(p.id[i]) {
                first[i] = first[r];
            }
        }
    }
    first
}

/// The particles looked up by global id: through a table indexed by id (less
/// the lowest) where the ids are dense (as the generators and files give
/// them), else through the (id, place) pairs sorted by id.
pub(crate) struct IdIndex {
    lo: u64,
    /// Place of each id `lo + k` at `table[k]` (`u32::MAX`: no particle);
    /// empty where the ids are sparse.
    table: Vec<u32>,
    /// (id, place) sorted, where the ids are sparse; else empty.
    sorted: Vec<(u64, u32)>,
    /// Whether some id is held twice (a particle and its periodic image);
    /// `get` then gives one of the two, the same one at every call.
    twice: bool,
}

impl IdIndex {
    pub(crate) fn new(ids: &[u64]) -> IdIndex {
        let n = ids.len();
        let (Some(&lo), Some(&hi)) = (ids.iter().min(), ids.iter().max()) else {
            return IdIndex { lo: 0, table: Vec::new(), sorted: Vec::new(), twice: false };
        };
        let mut twice = false;
        if hi - lo < 4 * n as u64 + 1024 {
            let mut table = vec![u32::MAX; (hi - lo + 1) as usize];
            for (i, &id) in ids.iter().enumerate() {
                let t = &mut table[(id - lo) as usize];
                twice |= *t != u32::MAX;
                *t = i as u32;
            }
            IdIndex { lo, table, sorted: Vec::new(), twice }
        } else {
            let mut sorted: Vec<(u64, u32)> = ids.iter().enumerate().map(|(i, &id)| (id, i as u32)).collect();
            sorted.sort_unstable();
            twice = sorted.windows(2).any(|w| w[0].0 == w[1].0);
            IdIndex { lo, table: Vec::new(), sorted, twice }
        }
    }

    /// The place of the particle of id `id`, if there is one.
    pub(crate) fn get(&self, id: u64) -> Option<usize> {
        if self.sorted.is_empty() {
            let k = id.checked_sub(self.lo)?;
            self.table.get(k as usize).copied().filter(|&i| i != u32::MAX).map(|i| i as usize)
        } else {
            self.sorted.binary_search_by_key(&id, |x| x.0).ok().map(|k| self.sorted[k].1 as usize)
        }
    }

    /// The particles' places in order of id (`None` if an id is held twice).
    fn into_order(self) -> Option<Vec<u32>> {
        if self.twice {
            None
        } else if self.sorted.is_empty() {
            Some(self.table.into_iter().filter(|&i| i != u32::MAX).collect())
        } else {
            Some(self.sorted.into_iter().map(|x| x.1).collect())
        }
    }
}

/// Rows of particles `0..n` laid end to end in `rows` (particle a's are
/// `rows[start[a]..start[a + 1]]`), cut into blocks of `ROW_BLOCK` particles,
/// each with its own part of `rows`, for the threads.
pub(crate) fn row_blocks<'a, T>(rows: &'a mut [T], start: &[u32], n: usize) -> Vec<(std::ops::Range<usize>, &'a mut [T])> {
    row_blocks_of(rows, start, n, ROW_BLOCK)
}

/// As [`row_blocks`], blocks of `block` particles.
pub(crate) fn row_blocks_of<'a, T>(
    rows: &'a mut [T],
    start: &[u32],
    n: usize,
    block: usize,
) -> Vec<(std::ops::Range<usize>, &'a mut [T])> {
    let block = block.max(1);
    let mut parts = Vec::with_capacity(n.div_ceil(block));
    let mut rest = rows;
    for b0 in (0..n).step_by(block) {
        let b1 = (b0 + block).min(n);
        let (part, r) = std::mem::take(&mut rest).split_at_mut((start[b1] - start[b0]) as usize);
        parts.push((b0..b1, part));
        rest = r;
    }
    parts
}

/// Places `0..n` cut into blocks of `block`, as ranges for the pool's threads
/// (collected in order).
fn blocks(n: usize, block: usize) -> impl IndexedParallelIterator<Item = std::ops::Range<usize>> {
    (0..n.div_ceil(block)).into_par_iter().map(move |b| b * block..((b + 1) * block).min(n))
}

/// How many particles ahead a row's history is fetched (`Rows::make_part`).
const HIST_PREFETCH: usize = 8;

/// Particles a thread takes at once in a light pass over the particles (the
/// displacement since the last build, the cell grid's bounding box and cells).
const PASS_BLOCK: usize = 8192;

/// Wide particles a thread searches at once (`CellGrid::search_wide`: each
/// scans many cells).
const WIDE_BLOCK: usize = 256;

/// Particles whose wall candidates among a small mesh's triangles are
/// narrowed down at once (`WallFind::append`).
const WALL_BLOCK: usize = 16;

/// Particles a thread takes at once when the pairs are found on several threads.
pub(crate) const ROW_BLOCK: usize = 2048;

/// The rows of a range of particles, to be filled in place: their pairs,
/// each with its history (`roll` empty unless the list keeps
/// rolling spring torques), laid out as the rows' partners in `keyed`.
struct Rows<'a> {
    pairs: &'a mut [(u32, u32)],
    hist: &'a mut [Vec3],
    roll: &'a mut [Vec3],
}

impl Rows<'_> {
    /// Fill the rows of particles `range`, their partners given as
    /// (partner id, partner) in `part` (the rows of `range` only: particle a's
    /// are `part[seg[a] - seg[range.start]..seg[a + 1] - seg[range.start]]`,
    /// and so are its places in `self`'s arrays): each row sorted by partner
    /// id, each pair with its history.
    fn make(&mut self, p: &Particles, seg: &[u32], part: &mut [(u64, u32)], old: &OldPairs, range: std::ops::Range<usize>) {
        let rolling = !self.roll.is_empty();
        let off = seg[range.start] as usize;
        // in storage order: a pair's place in the list changes no result
        let end = range.end;
        for a in range {
            // the history of a particle a few places on, fetched ahead: the
            // history is in order of ids, the rows in storage order, so each
            // row's run would otherwise start with a miss of the cache
            if let (OldPairs::Keyed { pairs: old_pair, first }, true) = (old, a + HIST_PREFETCH < end) {
                prefetch(old_pair, first[a + HIST_PREFETCH] as usize);
            }
            let places = seg[a] as usize - off..seg[a + 1] as usize - off;
            if places.is_empty() {
                continue;
            }
            let row = &mut part[places.clone()];
            // (partner id, partner): an id is held twice only by a particle
            // and its periodic image, told apart by their places
            row.sort_unstable();
            let ida = p.id[a];
            // a's old pairs are one run, in the row's order
            let mut cursor = old.run(a, ida);
            for (k, &(idb, b)) in places.zip(row.iter()) {
                let h = old.find(&p.id, &mut cursor, ida, idb);
                self.pairs[k] = (a as u32, b);
                self.hist[k] = h.shear;
                if rolling {
                    self.roll[k] = h.roll;
                }
            }
        }
    }
}

/// The entries `f` appends for places `0..n`, in order: on one thread one
/// pass; on several, blocks of places at once, each into its own array, then
/// copied into their places of the whole at once.
fn in_blocks<T: Copy + Send + Sync>(n: usize, threaded: bool, f: impl Fn(std::ops::Range<usize>, &mut Vec<T>) + Sync) -> Vec<T> {
    let mut out = Vec::new();
    if !threaded {
        f(0..n, &mut out);
        return out;
    }
    let parts: Vec<Vec<T>> = blocks(n, ROW_BLOCK)
        .map(|range| {
            let mut v = Vec::new();
            f(range, &mut v);
            v
        })
        .collect();
    joined(&mut out, parts.iter().map(|v| &v[..]));
    out
}

/// `out` made `parts` laid end to end, copied on the pool's threads.
fn joined<'a, T: Copy + Send + Sync + 'a>(out: &mut Vec<T>, parts: impl Iterator<Item = &'a [T]>) {
    let parts: Vec<&[T]> = parts.collect();
    let Some(&zero) = parts.iter().find_map(|p| p.first()) else {
        out.clear();
        return;
    };
    sized(out, parts.iter().map(|p| p.len()).sum(), zero);
    let mut jobs = Vec::with_capacity(parts.len());
    let mut rest = &mut out[..];
    for part in parts {
        let (s, r) = std::mem::take(&mut rest).split_at_mut(part.len());
        jobs.push((s, part));
        rest = r;
    }
    jobs.into_par_iter().for_each(|(s, part)| s.copy_from_slice(part));
}

/// `v` of length `len`, its first places as they were (a build that writes
/// every place needs no clearing pass over the arrays it reuses); new
/// places hold `x`.
fn sized<T: Copy>(v: &mut Vec<T>, len: usize, x: T) {
    v.truncate(len);
    room(v, len);
    v.resize(len, x);
}

/// Room in `v` for `len` items: where its buffer is too small, one of
/// `len` and a sixteenth more, not the doubling `Vec` would do (a list that
/// grows by 5% past its first build's size would otherwise hold twice the
/// memory it needs in every array of one place per pair).
fn room<T>(v: &mut Vec<T>, len: usize) {
    if len > v.capacity() {
        v.reserve_exact(len + len / 16 - v.len());
    }
}

/// `v` made `len` copies of `x` (in parallel where `threaded`), its buffer kept.
fn fill_with<T: Copy + Send + Sync>(v: &mut Vec<T>, len: usize, x: T, threaded: bool) {
    v.clear();
    room(v, len);
    if threaded {
        v.par_extend(rayon::iter::repeat_n(x, len));
    } else {
        v.resize(len, x);
    }
}

/// A stable counting sort by key. Every item of `chunks` (taken chunk after
/// chunk; item `g` is the g-th over all of them) whose `key` is `Some(k)`,
/// `k < n_keys`, goes to `out` as `val(g, item)`: in order of key, and the
/// items of one key in their order in `chunks`. Key k's places are
/// `start[k]..start[k + 1]`.
///
/// On several threads (`threaded`) the items are cut into one run per
/// thread (`runs`), each counted by key on its thread; a key's items of run
/// t go after its items of the runs before t (`run_places`), so each thread
/// then writes its own run's items where the serial sort puts them. Each
/// item is read twice in all, as on one thread, whatever the thread count.
#[allow(clippy::too_many_arguments)]
fn counting_sort<T: Sync, O: Copy + Send + Sync>(
    chunks: &[&[T]],
    n_keys: usize,
    key: impl Fn(&T) -> Option<usize> + Sync,
    val: impl Fn(usize, &T) -> O + Sync,
    zero: O,
    start: &mut Vec<u32>,
    out: &mut Vec<O>,
    threaded: bool,
) {
    let key = |x: &T| key(x).filter(|&k| k < n_keys);
    // each run beyond the first counts in an array of its own: where the
    // keys far outnumber the items (a sparse cell grid: up to 64 cells a
    // particle), they would cost more memory than the items, so one thread
    // sorts (at most SORT_KEYS_PER_ITEM more counts than items)
    let items: usize = chunks.iter().map(|c| c.len()).sum();
    let threads = if threaded { rayon::current_num_threads().max(1) } else { 1 };
    let parts = if n_keys.saturating_mul(threads - 1) > SORT_KEYS_PER_ITEM * items { 1 } else { threads };
    if parts == 1 {
        key_starts(start, n_keys, chunks.iter().flat_map(|c| c.iter()).filter_map(key));
        fill_with(out, start[n_keys] as usize, zero, false);
        let mut fill: Vec<u32> = start[..n_keys].to_vec();
        let mut g = 0;
        for c in chunks {
            for x in c.iter() {
                if let Some(f) = key(x).and_then(|k| fill.get_mut(k)) {
                    out[*f as usize] = val(g, x);
                    *f += 1;
                }
                g += 1;
            }
        }
        return;
    }
    let runs = runs(chunks, parts);
    let mut fill: Vec<Vec<u32>> = runs
        .par_iter()
        .map(|run| {
            let mut counts = vec![0u32; n_keys];
            for x in run.iter().flat_map(|(_, c)| c.iter()) {
                if let Some(k) = key(x) {
                    counts[k] += 1;
                }
            }
            counts
        })
        .collect();
    run_places(&mut fill, start, n_keys);
    fill_with(out, start[n_keys] as usize, zero, true);
    let places = Places::of(out);
    runs.par_iter().zip(fill.par_iter_mut()).for_each(|(run, fill)| {
        for &(g0, c) in run {
            for (j, x) in c.iter().enumerate() {
                if let Some(k) = key(x) {
                    places.put(fill[k] as usize, val(g0 + j, x));
                    fill[k] += 1;
                }
            }
        }
    });
}

/// Most extra counts the threaded counting sort keeps per item sorted
/// (4 bytes each): beyond that it sorts on one thread.
const SORT_KEYS_PER_ITEM: usize = 16;

/// The starts of `n_keys` keys' places (`n_keys + 1` entries) from the
/// keys of the items in turn, each item one place (keys from `n_keys` on
/// have none): the serial counting sort's count, and the incident lists'.
fn key_starts(start: &mut Vec<u32>, n_keys: usize, keys: impl Iterator<Item = usize>) {
    start.clear();
    start.resize(n_keys + 1, 0);
    for k in keys {
        if let Some(n) = start.get_mut(k + 1).filter(|_| k < n_keys) {
            *n += 1;
        }
    }
    for k in 0..n_keys {
        start[k + 1] += start[k];
    }
}

/// The items of `chunks` (taken chunk after chunk) cut into `parts` runs of
/// about equal length, in order, each as slices with the place over all
/// chunks of their first item.
fn runs<'a, T>(chunks: &[&'a [T]], parts: usize) -> Vec<Vec<(usize, &'a [T])>> {
    let total: usize = chunks.iter().map(|c| c.len()).sum();
    let per = total.div_ceil(parts).max(1);
    let mut runs: Vec<Vec<(usize, &[T])>> = (0..parts).map(|_| Vec::new()).collect();
    let mut g = 0;
    for &c in chunks {
        let mut rest = c;
        while !rest.is_empty() {
            let t = (g / per).min(parts - 1);
            let take = if t + 1 == parts { rest.len() } else { ((t + 1) * per - g).min(rest.len()) };
            runs[t].push((g, &rest[..take]));
            g += take;
            rest = &rest[take..];
        }
    }
    runs
}

/// From each run's count of items by key (`fill[t][k]`), the keys' starts
/// (`start`, `n_keys + 1` entries) and, in place of the counts, where each
/// run's first item of each key goes: after the key's items of the runs
/// before it.
fn run_places(fill: &mut [Vec<u32>], start: &mut Vec<u32>, n_keys: usize) {
    start.clear();
    start.resize(n_keys + 1, 0);
    let mut s = 0u32;
    for k in 0..n_keys {
        start[k] = s;
        for f in fill.iter_mut() {
            let n = f[k];
            f[k] = s;
            s += n;
        }
    }
    start[n_keys] = s;
}

/// An array written from several threads at once, each place by one
/// thread: the runs of a counting sort (`run_places` gives every run's
/// items of every key places of their own, which together are each place
/// once).
struct Places<'a, O> {
    ptr: *mut O,
    len: usize,
    /// The array, borrowed mutably for as long as the `Places` lives.
    _array: std::marker::PhantomData<&'a mut [O]>,
}

// SAFETY: `put` writes a place through the pointer; places are written by
// one thread each (see `put`), and the array is borrowed mutably for the
// `Places`' life (`of`), so nothing else reads or moves it meanwhile.
unsafe impl<O: Send> Sync for Places<'_, O> {}

impl<'a, O: Copy> Places<'a, O> {
    fn of(v: &'a mut [O]) -> Places<'a, O> {
        Places { ptr: v.as_mut_ptr(), len: v.len(), _array: std::marker::PhantomData }
    }

    /// Write `x` at place `i` (in bounds: checked). Callers write each
    /// place from one thread only (their counts and their writes take the
    /// same items by the same key), and no one reads the array until every
    /// thread is done (the end of the parallel loop).
    fn put(&self, i: usize, x: O) {
        assert!(i < self.len, "a counting sort's place {i} past its {} places", self.len);
        // SAFETY: in bounds (checked above), and no other thread writes or
        // reads place i meanwhile (the places of the runs are disjoint)
        unsafe { self.ptr.add(i).write(x) }
    }
}

/// The particles counting-sorted into cells (a quarter of the interaction
/// range along x, the whole range along y and z, or larger where the cell
/// count is capped), over their bounding box: `sorted[start[c]..start[c + 1]]`
/// holds cell c's particles as (id, index, [x, y, z, radius + skin / 2]),
/// cells in x-fastest order (each particle's own skin, `NeighborList::skins`).
struct CellGrid {
    dims: [usize; 3],
    /// How many cells out along x a particle's partners can be (one along y and z).
    reach_x: usize,
    start: Vec<u32>,
    /// Each particle's cell.
    cells: Vec<usize>,
    sorted: Vec<(u64, u32, [f64; 4])>,
    /// The range the cells cover (m): the half stencil finds every pair
    /// nearer than this, so it keeps the pairs within both this and their
    /// reach; the wide particles' own search, the rest.
    whole: f64,
    /// Each cell's length along x, y, z (m).
    size: [f64; 3],
    /// The largest radius + skin / 2 (m).
    h_max: f64,
    /// The places in `sorted` of the particles whose radius + skin / 2 is
    /// above `whole / 2` (only these can be in a pair whose reach is above
    /// `whole`), in order.
    wide: Vec<u32>,
}

impl CellGrid {
    /// Every pair within reach of which a particle at sorted places `range` is
    /// the one found first, as (the lower id's particle, the other): each pair
    /// once over all places. A particle looks at the rest of its own run of
    /// cells along x (the places after its own), the run of the next row along
    /// y, and the three runs of the next layer along z: half the 3 x 3 runs of
    /// its neighbourhood, whose other half finds it. A ghost pairs only with
    /// owned particles; members of one clump never pair; a particle never pairs
    /// with its own periodic image (the same id).
    fn search(&self, p: &Particles, range: std::ops::Range<usize>, out: &mut Vec<(u32, u32)>) {
        let n_own = p.owned();
        let [nx, ny, nz] = self.dims;
        let rx = self.reach_x;
        let whole = self.whole;
        for s in range {
            let (ida, a, qa) = self.sorted[s];
            let ghost_a = a as usize >= n_own;
            let clump_a = p.clump[a as usize];
            let c = self.cells[a as usize];
            let (cx, cy, cz) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let (x0, x1) = (cx.saturating_sub(rx), (cx + rx).min(nx - 1));
            let run = |z: usize, y: usize| {
                let base = (z * ny + y) * nx;
                self.start[base + x0] as usize..self.start[base + x1 + 1] as usize
            };
            let own = run(cz, cy);
            // each candidate written at the end of `out`, which then grows
            // by one where it is within reach: no branch on the distance
            // (about two in five candidates are within reach, a branch the
            // processor cannot predict)
            let mut visit = |r: std::ops::Range<usize>| {
                let mut len = out.len();
                out.resize(len + r.len(), (0, 0));
                for &(idb, b, qb) in &self.sorted[r] {
                    let (dx, dy, dz) = (qb[0] - qa[0], qb[1] - qa[1], qb[2] - qa[2]);
                    let cut = (qa[3] + qb[3]).min(whole);
                    let near = (dx * dx + dy * dy + dz * dz < cut * cut) & (idb != ida) & !(ghost_a & (b as usize >= n_own));
                    // (a clump's members never pair: a branch taken the same way for free particles)
                    let keep = near & (clump_a == 0 || p.clump[b as usize] != clump_a);
                    out[len] = if ida < idb { (a, b) } else { (b, a) };
                    len += keep as usize;
                }
                out.truncate(len);
            };
            visit(s + 1..own.end);
            if cy + 1 < ny {
                visit(run(cz, cy + 1));
            }
            if cz + 1 < nz {
                for y in cy.saturating_sub(1)..=(cy + 1).min(ny - 1) {
                    visit(run(cz + 1, y));
                }
            }
        }
    }

    /// The pairs within reach but farther apart than `whole` (which the
    /// half stencil leaves out) of the wide particles `wide[range]`, as
    /// [`CellGrid::search`] gives pairs: each searches every cell within
    /// its radius + skin / 2 plus the largest of these, and a pair of two
    /// wide particles is kept by the one of lower place in storage.
    fn search_wide(&self, p: &Particles, range: std::ops::Range<usize>, out: &mut Vec<(u32, u32)>) {
        let n_own = p.owned();
        let [nx, ny, nz] = self.dims;
        let (whole, narrow) = (self.whole, 0.5 * self.whole);
        let w2 = whole * whole;
        for &s in &self.wide[range] {
            let (ida, a, qa) = self.sorted[s as usize];
            let ghost_a = a as usize >= n_own;
            let clump_a = p.clump[a as usize];
            let c = self.cells[a as usize];
            let (cx, cy, cz) = (c % nx, (c / nx) % ny, c / (nx * ny));
            let far = qa[3] + self.h_max;
            let out_by = |k: usize| ((far / self.size[k]).ceil() as usize).min(self.dims[k]);
            let (kx, ky, kz) = (out_by(0), out_by(1), out_by(2));
            let (x0, x1) = (cx.saturating_sub(kx), (cx + kx).min(nx - 1));
            for z in cz.saturating_sub(kz)..=(cz + kz).min(nz - 1) {
                for y in cy.saturating_sub(ky)..=(cy + ky).min(ny - 1) {
                    let base = (z * ny + y) * nx;
                    let r = self.start[base + x0] as usize..self.start[base + x1 + 1] as usize;
                    for &(idb, b, qb) in &self.sorted[r] {
                        let (dx, dy, dz) = (qb[0] - qa[0], qb[1] - qa[1], qb[2] - qa[2]);
                        let d2 = dx * dx + dy * dy + dz * dz;
                        let cut = qa[3] + qb[3];
                        if d2 < w2 || d2 >= cut * cut || idb == ida || (ghost_a && b as usize >= n_own) {
                            continue;
                        }
                        if (clump_a != 0 && p.clump[b as usize] == clump_a) || (qb[3] > narrow && b < a) {
                            continue;
                        }
                        out.push(if ida < idb { (a, b) } else { (b, a) });
                    }
                }
            }
        }
    }

    /// (`uniform`: every one of `skins` is `skin`, as `set_skins` found;
    /// `threaded`: the bounding box and each particle's cell on the pool's
    /// threads; a minimum and a maximum are exact in any order.)
    fn new(p: &Particles, skin: f64, skins: &[f64], uniform: bool, period: &Vec3, threaded: bool) -> CellGrid {
        let n = p.len();
        let shifted: Vec<Vec3>;
        let pos: &[Vec3] = if p.image.is_empty() {
            &p.pos
        } else {
            shifted = (0..n).map(|i| p.list_pos(i, period)).collect();
            &shifted
        };
        let rmax = if threaded {
            p.radius.par_iter().with_min_len(PASS_BLOCK).cloned().reduce(|| 0.0, f64::max)
        } else {
            p.radius.iter().cloned().fold(0.0, f64::max)
        };
        // the grid spans the particles' bounding box
        let far = (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY));
        let (mut lo, mut hi) = if threaded {
            pos.par_iter()
                .with_min_len(PASS_BLOCK)
                .fold(|| far, |(lo, hi), x| (lo.inf(x), hi.sup(x)))
                .reduce(|| far, |a, b| (a.0.inf(&b.0), a.1.sup(&b.1)))
        } else {
            pos.iter().fold(far, |(lo, hi), x| (lo.inf(x), hi.sup(x)))
        };
        if n == 0 {
            lo = Vec3::zeros();
            hi = Vec3::zeros();
        }
        let ext = (hi - lo).add_scalar(1e-9);
        // cells as long as the interaction range along y and z and a quarter of
        // it along x, searched one cell out along y and z and four along x: a
        // particle scans 3 x 3 runs of cells (the cells along x are contiguous
        // in the sorted arrays), each 2.25 ranges long. Measured on H1-small's
        // whole run (one thread): 9 runs and about 33 candidates per particle
        // against 21 runs and 27 candidates with half-range cubes (5 x 5 x 5
        // cells, where each run held little more than one particle) and 8 runs
        // and 44 candidates with whole-range cubes. At most 64 cells per
        // particle (a huge domain with few particles must not allocate a huge
        // grid): where that cap binds the cells grow, keeping their shape.
        const SPLIT_X: usize = 4;
        let cap = (ext.x * ext.y * ext.z / (64.0 * n.max(1024) as f64)).cbrt() * (SPLIT_X as f64).cbrt();
        let range = (2.0 * rmax + skin).max(1e-12);
        let whole = range.max(cap);
        let cell = [whole / SPLIT_X as f64, whole, whole];
        let dims = [0, 1, 2].map(|k| ((ext[k] / cell[k]).floor() as usize).clamp(1, 1 << 20));
        let ncell = dims[0] * dims[1] * dims[2];
        let cell_of = |x: &Vec3| -> usize {
            let mut c = [0usize; 3];
            for k in 0..3 {
                let f = ((x[k] - lo[k]) / ext[k] * dims[k] as f64).floor();
                c[k] = (f.max(0.0) as usize).min(dims[k] - 1);
            }
            (c[2] * dims[1] + c[1]) * dims[0] + c[0]
        };
        // counting sort of particles into cells, with compact copies in cell order
        let cells: Vec<usize> = if threaded {
            pos.par_iter().with_min_len(PASS_BLOCK).map(cell_of).collect()
        } else {
            pos.iter().map(cell_of).collect()
        };
        let (mut start, mut sorted) = (Vec::new(), Vec::new());
        let copy = |i: usize, _: &usize| {
            let x = pos[i];
            (p.id[i], i as u32, [x.x, x.y, x.z, p.radius[i] + 0.5 * skins[i]])
        };
        counting_sort(&[&cells], ncell, |&c| Some(c), copy, (0, 0, [0.0; 4]), &mut start, &mut sorted, threaded);
        // the wide particles (none where every skin is the case's: radius +
        // skin / 2 is then at most (2 rmax + skin) / 2, at most whole / 2)
        let narrow = 0.5 * whole;
        let (wide, h_max) = if uniform {
            (Vec::new(), rmax + 0.5 * skin)
        } else {
            let wide: Vec<u32> = (0..sorted.len() as u32).filter(|&s| sorted[s as usize].2[3] > narrow).collect();
            (wide, sorted.iter().map(|x| x.2[3]).fold(0.0, f64::max))
        };
        let size = [0, 1, 2].map(|k| ext[k] / dims[k] as f64);
        CellGrid { dims, reach_x: SPLIT_X, start, cells, sorted, whole, size, h_max, wide }
    }
}

/// What a touching pair adds to its particle b (the higher id; a adds its
/// own part in the sweep itself): the force on a (b gets minus it) and the
/// torque on b.
#[derive(Clone, Copy, Debug, Default)]
pub struct PairOut {
    pub force: Vec3,
    pub torque_b: Vec3,
}

/// A law's constants ([`ContactLaw::Pair`]) for every pair and wall candidate
/// of a list, in list order: filled by the first force sweep after each build
/// (`forces`), typed by that sweep's law. One type-erased box per list, looked
/// at once per sweep, never per pair. A clone starts empty and is filled again
/// (the same numbers: the same expression of the same inputs).
#[derive(Default)]
pub struct LawConstants {
    /// The list build they belong to (`NeighborList::builds`; 0: none yet).
    build: u64,
    data: Option<Box<dyn std::any::Any + Send + Sync>>,
}

struct Filled<L: ContactLaw> {
    law: L,
    pairs: Vec<L::Pair>,
    walls: Vec<L::Pair>,
}

impl LawConstants {
    /// Forget the constants kept (the particles' radii or masses changed):
    /// the next sweep computes them again.
    pub fn forget(&mut self) {
        self.build = 0;
    }
    /// Whether these are `law`'s constants for list build `build`.
    pub fn holds<L: ContactLaw>(&self, law: L, build: u64) -> bool {
        self.build == build && self.data.as_ref().and_then(|d| d.downcast_ref::<Filled<L>>()).is_some_and(|f| f.law == law)
    }
    /// Keep `law`'s constants for list build `build`: one per pair, one per wall candidate.
    pub fn set<L: ContactLaw>(&mut self, law: L, build: u64, pairs: Vec<L::Pair>, walls: Vec<L::Pair>) {
        self.build = build;
        self.data = Some(Box::new(Filled { law, pairs, walls }));
    }
    /// The buffers of the constants kept (emptied; their room kept) where they
    /// are `L`'s, else new ones; none are kept after this. A new build's
    /// constants are written into the last one's room: the list never holds
    /// two sets at once (peak memory), and no new pages are touched.
    pub fn take_buffers<L: ContactLaw>(&mut self) -> (Vec<L::Pair>, Vec<L::Pair>) {
        match self.data.take().map(|d| d.downcast::<Filled<L>>()) {
            Some(Ok(f)) => {
                let Filled { mut pairs, mut walls, .. } = *f;
                pairs.clear();
                walls.clear();
                (pairs, walls)
            }
            _ => (Vec::new(), Vec::new()),
        }
    }
    /// The constants of pairs and of wall candidates (after [`LawConstants::set`] for this law).
    pub fn get<L: ContactLaw>(&self) -> (&[L::Pair], &[L::Pair]) {
        let f = self.data.as_ref().and_then(|d| d.downcast_ref::<Filled<L>>()).expect("law constants set for this law");
        (&f.pairs, &f.walls)
    }
}

impl Clone for LawConstants {
    fn clone(&self) -> Self {
        LawConstants::default()
    }
}

impl std::fmt::Debug for LawConstants {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "LawConstants {{ build: {}, filled: {} }}", self.build, self.data.is_some())
    }
}

/// The error for a particle that is no longer finite or left the domain.
pub fn particle_error(p: &Particles, i: usize, domain: &Domain) -> TalusError {
    let x = p.pos[i];
    let what = if x.iter().all(|c| c.is_finite()) && p.vel[i].iter().all(|c| c.is_finite()) {
        format!(
            "left the domain [{:.4}, {:.4}] x [{:.4}, {:.4}] x [{:.4}, {:.4}]",
            domain.lo.x, domain.hi.x, domain.lo.y, domain.hi.y, domain.lo.z, domain.hi.z
        )
    } else {
        "has a non-finite position or velocity (NaN or infinity)".to_string()
    };
    TalusError::Run(format!(
        "particle id {} (radius {:.4e} m) {what}: position ({:.6e}, {:.6e}, {:.6e}), velocity ({:.6e}, {:.6e}, {:.6e})",
        p.id[i], p.radius[i], x.x, x.y, x.z, p.vel[i].x, p.vel[i].y, p.vel[i].z
    ))
}

#[cfg(test)]
mod tests {
    use super::{sort_by_key_runs, Carry, NeighborList, SkinRule};
    use crate::dim::Vec3;
    use crate::particles::{ParticleInit, Particles};
    use crate::walls::{Plane, Shape, Wall};

    /// A list's history read in order of id (one thread and two, dense ids and
    /// sparse ones) is the history read in list order and sorted, entry for
    /// entry; and so is the list built from it again.
    #[test]
    fn the_history_read_in_order_of_id_is_the_sorted_history() {
        let mut seed = 777u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for sparse in [false, true] {
            // 12,000 spheres in storage order unrelated to id, overlapping a floor
            let mut p = Particles::default();
            let n = 12_000u64;
            for k in 0..n {
                let id = if sparse { (k * 7919) % 100_003 * 1_000 } else { (k * 7919) % n };
                let pos = Vec3::new(next() * 0.06, next() * 0.06, next() * 0.03);
                p.push_sphere(&ParticleInit { id, pos, vel: Vec3::zeros(), omega: Vec3::zeros(), radius: 1e-3 }, 2500.0, 0);
            }
            let floor = Wall::new("floor", Shape::Plane(Plane { point: Vec3::new(0.0, 0.0, 0.005), normal: Vec3::z() }), 0);
            let walls = [floor];
            let mut nl = NeighborList::new(5e-4);
            nl.build(&p, &walls);
            assert!(
                nl.pairs.len() > 10_000 && nl.wall_feat.len() > 500,
                "{} pairs, {} wall candidates",
                nl.pairs.len(),
                nl.wall_feat.len()
            );
            // history on about half the pairs and wall candidates
            for h in nl.pair_hist.iter_mut().chain(nl.wall_hist.iter_mut()) {
                if next() < 0.5 {
                    *h = Vec3::new(next(), next(), next());
                }
            }
            let want = nl.history_sorted(&p.id);
            assert!(want.pairs.windows(2).all(|w| w[0].0 < w[1].0) && want.walls.windows(2).all(|w| w[0].0 < w[1].0));
            assert!(want.pairs.len() > 5_000 && want.walls.len() > 200);
            assert_eq!(nl.history_in_id_order(&p.id, false).as_ref(), Some(&want), "one thread, sparse ids {sparse}");
            assert_eq!(
                pool.install(|| nl.history_in_id_order(&p.id, true)).as_ref(),
                Some(&want),
                "two threads, sparse ids {sparse}"
            );
            assert_eq!(nl.take_history(&p), want);
            // and the list made again from it holds the same history
            let mut again = NeighborList::new(5e-4);
            again.build_with(&p, &walls, Carry::Keyed(&want));
            assert_eq!(again.history_sorted(&p.id), want);
        }
    }

    /// A list that carries its own history (`Carry::Own`) builds the list that
    /// the history read out by ids builds (`Carry::Keyed`), bit for bit: with
    /// the particles in the same places (along the rows) and in another
    /// storage order (read out by the ids of the last build); shear and
    /// rolling histories, some of them -0.
    #[test]
    fn a_list_carrying_its_own_history_builds_the_list_the_keyed_history_builds() {
        let mut seed = 4242u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let floor = Wall::new("floor", Shape::Plane(Plane { point: Vec3::new(0.0, 0.0, 0.004), normal: Vec3::z() }), 0);
        let walls = [floor];
        let bits = |v: &[Vec3]| v.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
        // the same pairs and wall candidates with the same history, bit for bit
        let same = |own: &NeighborList, keyed: &NeighborList, what: &str| {
            assert_eq!(own.pairs, keyed.pairs);
            assert_eq!(bits(&own.pair_hist), bits(&keyed.pair_hist), "{what}");
            assert_eq!(bits(&own.pair_roll), bits(&keyed.pair_roll), "{what}");
            assert_eq!(own.wall_feat, keyed.wall_feat);
            assert_eq!(bits(&own.wall_hist), bits(&keyed.wall_hist), "{what}");
            assert_eq!(bits(&own.wall_roll), bits(&keyed.wall_roll), "{what}");
        };
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for (rolling, threaded) in [(false, false), (true, false), (false, true), (true, true)] {
            let mut p = Particles::default();
            for k in 0..9_000u64 {
                let pos = Vec3::new(next() * 0.05, next() * 0.05, next() * 0.02);
                p.push_sphere(
                    &ParticleInit { id: (k * 7919) % 9_000, pos, vel: Vec3::zeros(), omega: Vec3::zeros(), radius: 1e-3 },
                    2500.0,
                    0,
                );
            }
            let mut nl = NeighborList::new(5e-4);
            nl.rolling_history = rolling;
            nl.threaded = threaded;
            nl.build(&p, &walls);
            for v in [&mut nl.pair_hist, &mut nl.pair_roll, &mut nl.wall_hist, &mut nl.wall_roll] {
                for h in v.iter_mut() {
                    let r = next();
                    *h = if r < 0.4 {
                        Vec3::new(next(), next(), next())
                    } else if r < 0.5 {
                        Vec3::new(-0.0, 0.0, -0.0)
                    } else {
                        Vec3::zeros()
                    };
                }
            }
            // the particles move by up to a radius: pairs and wall contacts come and go
            let before = nl.take_history(&p);
            for x in p.pos.iter_mut() {
                *x += Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 1e-3;
            }
            let mut shuffled = p.clone();
            let mut perm: Vec<usize> = (0..p.len()).collect();
            perm.reverse();
            shuffled.permute(&perm);
            for q in [&p, &shuffled] {
                let (mut own, mut keyed) = (nl.clone(), nl.clone());
                pool.install(|| {
                    own.build_with(q, &walls, Carry::Own);
                    keyed.build_with(q, &walls, Carry::Keyed(&before));
                });
                let same_places = std::ptr::eq(q, &p);
                assert!(own.pairs.len() > 10_000 && own.wall_feat.len() > 500);
                same(&own, &keyed, &format!("rolling {rolling}, same places {same_places}"));
                // some history came along
                assert!(own.pair_hist.iter().filter(|h| **h != Vec3::zeros()).count() > 1_000);
                assert!(own.wall_hist.iter().filter(|h| **h != Vec3::zeros()).count() > 50);
            }
            // particles that arrive (every tenth id: not in the last build)
            // with history of their own (`Carry::OwnAnd`): as the keyed
            // history of those that stay merged with what arrived
            let stay: Vec<usize> = (0..p.len()).filter(|&i| p.id[i] % 10 != 0).collect();
            let mut old_p = p.clone();
            old_p.permute(&stay);
            let mut old = NeighborList::new(5e-4);
            old.rolling_history = rolling;
            old.threaded = threaded;
            old.build(&old_p, &walls);
            let mut full = old.clone();
            full.build(&p, &walls);
            for (nl, scale) in [(&mut old, 1.0), (&mut full, 3.0)] {
                for v in [&mut nl.pair_hist, &mut nl.pair_roll, &mut nl.wall_hist, &mut nl.wall_roll] {
                    for h in v.iter_mut() {
                        *h = if next() < 0.5 { Vec3::new(next(), next(), next()) * scale } else { Vec3::zeros() };
                    }
                }
            }
            let mut arrived = full.take_history(&p);
            arrived.pairs.retain(|((a, b), _)| a % 10 == 0 || b % 10 == 0);
            arrived.walls.retain(|((a, _, _), _)| a % 10 == 0);
            let mut merged = old.take_history(&old_p);
            merged.merge(arrived.clone());
            for x in p.pos.iter_mut() {
                *x += Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5) * 1e-3;
            }
            let (mut own, mut keyed) = (old.clone(), old.clone());
            pool.install(|| {
                own.build_with(&p, &walls, Carry::OwnAnd(&arrived));
                keyed.build_with(&p, &walls, Carry::Keyed(&merged));
            });
            same(&own, &keyed, &format!("rolling {rolling}, arrivals"));
            // both sources were read: values of the old list (below 1) and received (above 1)
            let big = own.pair_hist.iter().filter(|h| h.x > 1.0).count();
            let small = own.pair_hist.iter().filter(|h| h.x > 0.0 && h.x < 1.0).count();
            assert!(big > 100 && small > 1_000, "{big} received, {small} kept");
            assert!(own.wall_hist.iter().filter(|h| h.x > 1.0).count() > 5);
        }
    }

    /// Rows of a list in storage order (each particle's partners in order of
    /// id, particles in any order), with and without an id held twice: the
    /// run sort gives the whole sort's result.
    #[test]
    fn sorting_by_runs_gives_the_sorted_history() {
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            seed >> 33
        };
        for twice in [false, true] {
            let mut v: Vec<((u64, u64), u32)> = Vec::new();
            let mut owners: Vec<u64> = (0..500).map(|_| next() % 10_000).collect();
            owners.sort_unstable();
            owners.dedup();
            if twice {
                let o = owners[7];
                owners.push(o);
            }
            // storage order: shuffled
            for i in (1..owners.len()).rev() {
                owners.swap(i, next() as usize % (i + 1));
            }
            for &a in &owners {
                let mut partners: Vec<u64> = (0..next() % 6).map(|_| a + 1 + next() % 50).collect();
                partners.sort_unstable();
                partners.dedup();
                v.extend(partners.into_iter().map(|b| ((a, b), (a * 7 + b) as u32)));
            }
            let mut want = v.clone();
            want.sort_unstable_by_key(|x| x.0);
            sort_by_key_runs(&mut v, |k| k.0);
            let keys = |x: &[((u64, u64), u32)]| x.iter().map(|e| e.0).collect::<Vec<_>>();
            assert_eq!(keys(&v), keys(&want));
            // each entry kept with its value
            let mut got = v.clone();
            got.sort_unstable();
            want.sort_unstable();
            assert_eq!(got, want);
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(64))]
        /// The counting sort on 1, 2 and 3 threads is the serial stable sort:
        /// each key's items in their order, over chunks of any sizes (empty
        /// ones too), items without a key or with one past the last left
        /// out, keys with no items, no keys at all, more threads than keys.
        #[test]
        fn the_counting_sort_on_threads_is_the_stable_sort(
            items in proptest::collection::vec((0usize..48, proptest::bool::weighted(0.8)), 0..600),
            cuts in proptest::collection::vec(0usize..600, 0..5),
            // (many more keys than items: the sort runs on one thread)
            n_keys in proptest::prop_oneof![0usize..45, 1000usize..12000],
        ) {
            // keys from n_keys up are left out, as items without one
            let key = |&(k, has): &(usize, bool)| has.then_some(k);
            let val = |g: usize, x: &(usize, bool)| (x.0 as u32, g as u32);
            // the chunks: `items` cut at `cuts`
            let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c.min(items.len())).collect();
            cuts.push(0);
            cuts.push(items.len());
            cuts.sort_unstable();
            let chunks: Vec<&[(usize, bool)]> = cuts.windows(2).map(|w| &items[w[0]..w[1]]).collect();
            // the stable sort by key
            let mut want: Vec<(u32, u32)> =
                items.iter().enumerate().filter(|(_, x)| x.1 && x.0 < n_keys).map(|(g, x)| val(g, x)).collect();
            want.sort_by_key(|x| x.0);
            let mut want_start = vec![0u32; n_keys + 1];
            for &(k, _) in &want {
                want_start[k as usize + 1] += 1;
            }
            for k in 0..n_keys {
                want_start[k + 1] += want_start[k];
            }
            for threads in [1, 2, 3] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let (mut start, mut out) = (vec![7u32; 3], vec![(9u32, 9u32); 5]);
                pool.install(|| super::counting_sort(&chunks, n_keys, key, val, (0, 0), &mut start, &mut out, threads > 1));
                proptest::prop_assert_eq!(&out, &want, "{} threads", threads);
                proptest::prop_assert_eq!(&start, &want_start, "{} threads", threads);
            }
        }
    }

    /// Particles in a box over a floor at z = 0.002 (300 of radius 0.8-1.2
    /// mm, or `n` more densely), a fraction `fast` of them moving at up to
    /// `top` m/s (the rest at rest), from a seed.
    fn cloud(seed: u64, n: usize, fast: f64, top: f64) -> Particles {
        let mut s = seed.wrapping_mul(2862933555777941757).wrapping_add(3037000493);
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let side = 0.02 * (n as f64 / 300.0).cbrt();
        let mut p = Particles::default();
        for id in 0..n as u64 {
            let pos = Vec3::new(next() * side, next() * side, 0.002 + next() * side / 2.0);
            let radius = 8e-4 + 4e-4 * next();
            let vel = if next() < fast { Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize() * top * next() } else { Vec3::zeros() };
            p.push_sphere(&ParticleInit { id, pos, vel, omega: Vec3::zeros(), radius }, 2500.0, 0);
        }
        p
    }

    /// The rule of these tests: skin 5e-4 m, s_k = 5e-4 |v_k| (so 1-4 skins
    /// for speeds of 1-4 m/s).
    fn rule() -> SkinRule {
        SkinRule { per_speed: 5e-4, cap: 4.0 }
    }

    /// With skins of their own (a third of the particles fast, up to four
    /// skins), the list holds exactly the pairs within r_a + r_b + (s_a +
    /// s_b) / 2 and the floor's candidates within r + s, on one thread and
    /// two (a cloud large enough for the threaded search; pairs within 1e-12
    /// of their reach are not looked at); and with no rule, those within r_a
    /// + r_b + skin, every skin the case's.
    #[test]
    fn a_list_with_skins_of_their_own_holds_every_pair_within_reach() {
        let skin = 5e-4;
        let floor = Wall::new("floor", Shape::Plane(Plane { point: Vec3::new(0.0, 0.0, 0.002), normal: Vec3::z() }), 0);
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for (seed, with_rule) in [(1u64, true), (2, true), (3, false)] {
            let p = cloud(seed, 6000, 0.3, 4.0);
            for threaded in [false, true] {
                let mut nl = NeighborList::new(skin);
                nl.threaded = threaded;
                if with_rule {
                    nl.skin_rule = rule();
                    nl.skin_limit = f64::INFINITY;
                }
                pool.install(|| nl.build(&p, std::slice::from_ref(&floor)));
                let s_of = |i: usize| if with_rule { rule().of(skin, f64::INFINITY, p.vel[i].norm()) } else { skin };
                assert_eq!(nl.uniform, !with_rule);
                if with_rule {
                    assert!(nl.skins.iter().any(|&s| s > 3.0 * skin) && nl.skins.iter().all(|&s| (skin..=4.0 * skin).contains(&s)));
                }
                let listed: std::collections::HashSet<(u32, u32)> = nl.pairs.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
                assert_eq!(listed.len(), nl.pairs.len(), "a pair listed twice");
                let (mut within, mut wide) = (0, 0);
                for a in 0..p.len() {
                    for b in a + 1..p.len() {
                        let d = (p.pos[a] - p.pos[b]).norm();
                        let reach = p.radius[a] + p.radius[b] + 0.5 * (s_of(a) + s_of(b));
                        if (d - reach).abs() < 1e-12 * reach {
                            continue;
                        }
                        let is = listed.contains(&(a as u32, b as u32));
                        assert_eq!(is, d < reach, "seed {seed}, threaded {threaded}: pair {a} {b} at {d:e} m, reach {reach:e} m");
                        within += is as usize;
                        wide += (is && d >= 2.0 * 1.2e-3 + skin) as usize;
                    }
                    let z = p.pos[a].z - 0.002;
                    let cand = nl.wall_start[a + 1] > nl.wall_start[a];
                    assert_eq!(cand, z > -p.radius[a] && z < p.radius[a] + s_of(a), "particle {a} and the floor");
                }
                assert!(within > 1000, "{within} pairs");
                // pairs beyond the cells' range are there (and only) with the rule
                assert_eq!(wide > 0, with_rule, "{wide} pairs beyond the cells' range");
            }
        }
    }

    /// A list that `Moved::stale` calls fresh holds every touching pair and
    /// every touching wall contact, however the particles moved (see
    /// `a_list_called_fresh_misses_no_contact`), with `skins_of_their_own`
    /// or with the case's skin for all.
    fn called_fresh_misses_nothing(
        seed: u64,
        a_frac: f64,
        b_frac: f64,
        c_frac: f64,
        w_frac: f64,
        jitter: f64,
        skins_of_their_own: bool,
    ) -> Result<(), proptest::test_runner::TestCaseError> {
        let (skin, z_floor) = (5e-4, 0.002);
        let mut p = cloud(seed, 300, if skins_of_their_own { 0.3 } else { 0.0 }, 4.0);
        let mut s = seed.wrapping_add(77);
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        let floor = |z: f64| Wall::new("floor", Shape::Plane(Plane { point: Vec3::new(0.0, 0.0, z), normal: Vec3::z() }), 0);
        let mut nl = NeighborList::new(skin);
        if skins_of_their_own {
            nl.skin_rule = rule();
            nl.skin_limit = f64::INFINITY;
        }
        nl.build(&p, &[floor(z_floor)]);
        let sk = nl.skins.clone();
        let listed: std::collections::HashSet<(u32, u32)> = nl.pairs.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
        // two particles just beyond each other's reach: the closest unlisted pair
        let n = p.len();
        let mut pick = None;
        for a in 0..n {
            for b in a + 1..n {
                let gap = (p.pos[a] - p.pos[b]).norm() - (p.radius[a] + p.radius[b]) - 0.5 * (sk[a] + sk[b]);
                if !listed.contains(&(a as u32, b as u32)) && pick.is_none_or(|(g, _, _)| gap < g) {
                    pick = Some((gap, a, b));
                }
            }
        }
        let (gap, a, b) = pick.unwrap();
        // every particle jittered within `jitter` of its skin, a and b pushed
        // together by fractions of theirs
        let mut moves = Vec::new();
        for i in 0..n {
            let d = if i == a || i == b {
                let towards = (p.pos[if i == a { b } else { a }] - p.pos[i]).normalize();
                towards * if i == a { a_frac } else { b_frac } * sk[i]
            } else {
                Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize() * jitter * sk[i] * next()
            };
            moves.push(d);
        }
        // and the particle closest to the floor that is not its candidate
        // pushed down onto it, the floor raised by w
        let gap_floor = |i: usize| p.pos[i].z - z_floor - p.radius[i];
        let low = (0..n)
            .filter(|&i| i != a && i != b && nl.wall_start[i] == nl.wall_start[i + 1])
            .min_by(|&i, &j| gap_floor(i).total_cmp(&gap_floor(j)))
            .unwrap();
        let low_gap = gap_floor(low);
        moves[low] = Vec3::new(0.0, 0.0, -c_frac * sk[low]);
        let mut first = f64::NEG_INFINITY;
        for (i, d) in moves.iter().enumerate() {
            let x0 = p.pos[i];
            p.pos[i] += d;
            first = first.max((p.pos[i] - x0).norm() - 0.5 * sk[i]);
        }
        let w = w_frac * skin;
        let domain = super::Domain { lo: Vec3::new(-1.0, -1.0, -1.0), hi: Vec3::new(1.0, 1.0, 1.0) };
        let moved = nl.displacement(&p, &domain).unwrap();
        proptest::prop_assert_eq!(moved.first, first);
        let stale = moved.stale(skin, w, 0.0);
        let push = a_frac * sk[a] + b_frac * sk[b];
        let room = 0.5 * (sk[a] + sk[b]) + gap;
        proptest::prop_assert!(!(push > room * 1.000001) || stale, "a and b closed {} m of a {} m gap", push, room);
        let down = c_frac * sk[low] + w;
        proptest::prop_assert!(!(down > low_gap * 1.000001) || stale, "a particle and the floor closed {} m of a {} m gap", down, low_gap);
        if !stale {
            let wall = floor(z_floor + w);
            for i in 0..n {
                for j in i + 1..n {
                    if (p.pos[i] - p.pos[j]).norm() < p.radius[i] + p.radius[j] {
                        proptest::prop_assert!(listed.contains(&(i as u32, j as u32)), "pair {} {} touches, not listed", i, j);
                    }
                }
                if wall.contact(0, &p.pos[i], p.radius[i]).is_some() {
                    let (lo, hi) = (nl.wall_start[i] as usize, nl.wall_start[i + 1] as usize);
                    proptest::prop_assert!(hi > lo, "particle {} touches the floor, not a candidate", i);
                }
            }
        }
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::test_runner::Config::with_cases(48))]
        /// A list that `Moved::stale` calls fresh holds every touching pair and
        /// every touching wall contact, however the particles moved: here two
        /// chosen particles (outside each other's reach) are pushed straight
        /// towards each other and a third (not the floor's candidate) down
        /// towards a floor that itself moved up, by amounts up to 1.3 of
        /// their skins, the rest jittered. Whenever the list is called
        /// fresh, no contact is missing; and the push that closes a pair
        /// beyond its reach is always called stale. Every particle with the
        /// case's skin, and (a third of them fast) skins of their own.
        #[test]
        fn a_list_called_fresh_misses_no_contact(
            seed in 0u64..1_000_000,
            a_frac in 0.0f64..1.3,
            b_frac in 0.0f64..1.3,
            c_frac in 0.0f64..1.3,
            w_frac in 0.0f64..1.3,
            jitter in 0.0f64..0.3,
            own in proptest::bool::ANY,
        ) {
            called_fresh_misses_nothing(seed, a_frac, b_frac, c_frac, w_frac, jitter, own)?;
        }
    }
}

