//! Migration: particles whose owner changed (they left the box, or the planes
//! moved) go to their new owner with their Gear derivatives and every contact
//! history entry that involves them; then the owned particles are put in the
//! storage order asked for (`crate::order`: by grid cell, along a Hilbert
//! curve, by id, or shuffled). The
//! history is routed by one [`Router`] whether it comes from the current list
//! (at a rebuild: local indices, no lookups) or keyed by ids (set-up, restart).

use super::{bin, unbin, Parallel};
use crate::dim::Vec3;
use crate::integrate::GearState;
use crate::neighbor::{Carry, Hist, History, NeighborList};
use crate::order::StorageOrder;
use crate::particles::{Particles, Record};
use serde::{Deserialize, Serialize};

/// Where a list rebuilt after a migration takes its contact history from
/// (see [`crate::neighbor::Carry`]).
pub enum Carried {
    Own,
    Keyed(History),
    OwnAnd(History),
}

impl Carried {
    /// The build's `Carry` of it.
    pub fn carry(&self) -> Carry<'_> {
        match self {
            Carried::Own => Carry::Own,
            Carried::Keyed(h) => Carry::Keyed(h),
            Carried::OwnAnd(h) => Carry::OwnAnd(h),
        }
    }
}

/// What migrates with particles to one rank.
#[derive(Serialize, Deserialize, Default)]
pub(super) struct Migration {
    recs: Vec<Record>,
    gear: Vec<Vec<Vec3>>,
    hist: History,
}

/// Routes history entries: to this rank if one of the entry's particles is
/// owned here after the migration, and to each other rank one of them moves to
/// (once per rank). Entries involving no particle of this rank are dropped.
struct Router<'a> {
    me: usize,
    keep: History,
    out: &'a mut [Migration],
}

impl Router<'_> {
    /// A pair entry whose particles go to `da` and `db` (None: not owned here).
    fn pair(&mut self, e: ((u64, u64), Hist), da: Option<usize>, db: Option<usize>) {
        if da == Some(self.me) || db == Some(self.me) {
            self.keep.pairs.push(e);
        }
        if let Some(r) = da.filter(|&r| r != self.me) {
            self.out[r].hist.pairs.push(e);
        }
        if let Some(r) = db.filter(|&r| r != self.me && Some(r) != da) {
            self.out[r].hist.pairs.push(e);
        }
    }

    /// A wall entry of a particle that goes to `d`.
    fn wall(&mut self, e: ((u64, u16, u32), Hist), d: usize) {
        if d == self.me {
            self.keep.walls.push(e);
        } else {
            self.out[d].hist.walls.push(e);
        }
    }
}

impl Parallel {
    /// Keep, out of the full set of particles (every rank holds the same), the
    /// ones this rank owns; with their Gear derivatives and the history that
    /// involves them. Used at set-up and at a restart.
    pub fn take_own(&self, p: &mut Particles, gear: &mut GearState, hist: &mut History) {
        let me = self.rank();
        let keep: Vec<usize> = (0..p.len()).filter(|&i| self.dec.owner(&p.pos[i]) == me).collect();
        let rows: Vec<Vec<Vec3>> = keep.iter().map(|&i| gear.get(i)).collect();
        p.permute(&keep);
        gear.set_all(&rows);
        let mut ids = p.id.clone();
        ids.sort_unstable();
        let mine = |id: u64| ids.binary_search(&id).is_ok();
        hist.pairs.retain(|((a, b), _)| mine(*a) || mine(*b));
        hist.walls.retain(|((a, _, _), _)| mine(*a));
    }

    /// Planes for equal particle counts, from the full set of positions (every rank has the same).
    pub fn refit_all(&mut self, pos: &[Vec3]) {
        self.dec.fit(&super::comm::Comm::Serial, pos, &vec![1.0; pos.len()]);
    }

    /// The new owner of each owned particle, and one empty message per rank.
    fn destinations(&self, p: &Particles) -> (Vec<usize>, Vec<Migration>) {
        let dest = (0..p.owned()).map(|i| self.dec.owner(&p.pos[i])).collect();
        (dest, (0..self.size()).map(|_| Migration::default()).collect())
    }

    /// Pack the owned particles that leave (with their Gear rows) into their messages.
    fn pack_leaving(&self, p: &Particles, gear: &GearState, dest: &[usize], out: &mut [Migration]) {
        let me = self.rank();
        for (i, &d) in dest.iter().enumerate() {
            if d != me {
                out[d].recs.push(p.record(i));
                out[d].gear.push(gear.get(i));
            }
        }
    }

    /// At a list rebuild: migrate the particles whose owner changed with their
    /// Gear derivatives and the contact history that involves them (read from
    /// the current list by local index), then remake the ghosts. Returns where
    /// the new list takes its history from: on one rank without ghosts, the
    /// list itself ([`Carried::Own`]); on several, the list itself and what
    /// came with the particles that arrived ([`Carried::OwnAnd`]: only the
    /// leavers' history is read out and sent); where periodic images hold an
    /// id twice, the keyed history of every particle that stays, merged with
    /// what arrived ([`Carried::Keyed`]).
    pub fn migrate_from_list(&mut self, p: &mut Particles, gear: &mut GearState, nl: &NeighborList) -> Carried {
        let (dest, mut out) = self.destinations(p);
        let alone = self.size() == 1 && p.ghosts == 0;
        let rows_fit = nl.row_start.len() == p.len() + 1 && nl.incident_start.len() == p.owned() + 1;
        let own_rows = alone || (p.image.is_empty() && rows_fit);
        // the history the list cannot find in itself
        let hist = if alone {
            History::default()
        } else if own_rows {
            self.route_leaving(p, nl, &dest, &mut out);
            History::default()
        } else {
            self.route_history(p, nl, &dest, &mut out)
        };
        p.drop_ghosts();
        self.pack_leaving(p, gear, &dest, &mut out);
        let hist = self.exchange_owned(p, gear, hist, out, &dest);
        match (alone, own_rows) {
            (true, _) => Carried::Own,
            (false, true) => Carried::OwnAnd(hist),
            (false, false) => Carried::Keyed(hist),
        }
    }

    /// The contact history of the particles that leave, read from the list
    /// (their rows, the pairs in which they are the higher id, and their
    /// wall candidates) into the messages for their new owners: each pair
    /// entry once for each rank other than this one that one of its
    /// particles goes to, as [`Router`] sends them.
    fn route_leaving(&self, p: &Particles, nl: &NeighborList, dest: &[usize], out: &mut [Migration]) {
        let (me, n) = (self.rank(), p.owned());
        let with_walls = n.min(nl.wall_start.len().saturating_sub(1));
        for (i, &r) in dest.iter().enumerate() {
            if r == me {
                continue;
            }
            let hist = &mut out[r].hist;
            for k in nl.row_start[i] as usize..nl.row_start[i + 1] as usize {
                let h = nl.pair_entry(k);
                if !h.is_zero() {
                    hist.pairs.push(((p.id[i], p.id[nl.pairs[k].1 as usize]), h));
                }
            }
            for &k in &nl.incident[nl.incident_start[i] as usize..nl.incident_start[i + 1] as usize] {
                let a = nl.pairs[k as usize].0 as usize;
                // sent with a where a goes to the same rank
                if a < n && dest[a] == r {
                    continue;
                }
                let h = nl.pair_entry(k as usize);
                if !h.is_zero() {
                    hist.pairs.push(((p.id[a], p.id[i]), h));
                }
            }
            if i < with_walls {
                for k in nl.wall_start[i] as usize..nl.wall_start[i + 1] as usize {
                    let h = nl.wall_entry(k);
                    if !h.is_zero() {
                        let (w, f) = nl.wall_feat[k];
                        hist.walls.push(((p.id[i], w, f), h));
                    }
                }
            }
        }
    }

    /// The contact history of the list's pairs and wall candidates by ids:
    /// each entry kept (sorted by key) where one of its particles stays on
    /// this rank and added to `out[r]` where one goes to rank r.
    fn route_history(&self, p: &Particles, nl: &NeighborList, dest: &[usize], out: &mut [Migration]) -> History {
        let n = p.owned();
        let mut route = Router { me: self.rank(), keep: History::default(), out };
        for (k, &(a, b)) in nl.pairs.iter().enumerate() {
            let h = nl.pair_entry(k);
            if !h.is_zero() {
                let (a, b) = (a as usize, b as usize);
                route.pair(((p.id[a], p.id[b]), h), (a < n).then(|| dest[a]), (b < n).then(|| dest[b]));
            }
        }
        for i in 0..n.min(nl.wall_start.len().saturating_sub(1)) {
            for k in nl.wall_start[i] as usize..nl.wall_start[i + 1] as usize {
                let h = nl.wall_entry(k);
                if !h.is_zero() {
                    let (w, f) = nl.wall_feat[k];
                    route.wall(((p.id[i], w, f), h), dest[i]);
                }
            }
        }
        let mut hist = route.keep;
        // the list is in storage order, each row in order of partner id: sort
        // the kept history by key, run by run
        crate::neighbor::sort_by_key_runs(&mut hist.pairs, |k| k.0);
        crate::neighbor::sort_by_key_runs(&mut hist.walls, |k| k.0);
        hist
    }

    /// Migrate particles that left this rank's box (used at set-up and restart,
    /// with the history given keyed by ids), then rebuild the ghost layer.
    pub fn migrate(&mut self, p: &mut Particles, gear: &mut GearState, hist: History) -> History {
        p.drop_ghosts();
        let (dest, mut out) = self.destinations(p);
        // an entry's particles looked up by id (each held once: no ghosts)
        let index = crate::neighbor::IdIndex::new(&p.id);
        let to = |id: u64| index.get(id).map(|i| dest[i]);
        let mut route = Router { me: self.rank(), keep: History::default(), out: &mut out };
        for e in hist.pairs {
            route.pair(e, to(e.0 .0), to(e.0 .1));
        }
        for e in hist.walls {
            if let Some(d) = to(e.0 .0) {
                route.wall(e, d);
            }
        }
        let hist = route.keep;
        self.pack_leaving(p, gear, &dest, &mut out);
        self.exchange_owned(p, gear, hist, out, &dest)
    }

    /// Send the migrants (`out[r]` for rank r), receive this rank's, merge them
    /// in id order with the particles that stay (`dest[i] == me`), then remake the ghosts.
    fn exchange_owned(
        &mut self,
        p: &mut Particles,
        gear: &mut GearState,
        mut hist: History,
        out: Vec<Migration>,
        dest: &[usize],
    ) -> History {
        let me = self.rank();
        let msgs: Vec<Vec<u8>> =
            out.iter().enumerate().map(|(r, m)| if r == me || m.recs.is_empty() { Vec::new() } else { bin(m) }).collect();
        let got = self.comm.exchange_bytes(&msgs);
        // inserted particles arrive from nowhere, without Gear rows or history
        let mut arrived: Vec<(Record, Vec<Vec3>)> = std::mem::take(&mut self.inserted).into_iter().map(|r| (r, Vec::new())).collect();
        let mut add = History::default();
        for (r, m) in got.iter().enumerate() {
            if r == me || m.is_empty() {
                continue;
            }
            let m: Migration = unbin(m);
            let mut g = m.gear.into_iter();
            for rec in m.recs {
                arrived.push((rec, g.next().unwrap_or_default()));
            }
            add.pairs.extend(m.hist.pairs);
            add.walls.extend(m.hist.walls);
        }
        if dest.iter().any(|&d| d != me) || !arrived.is_empty() {
            merge_arrivals(p, gear, dest, me, arrived, self.order == StorageOrder::Id);
            if !add.pairs.is_empty() || !add.walls.is_empty() {
                add.normalise();
                hist.merge(add);
            }
        }
        self.reorder(p, gear);
        self.make_ghosts(p);
        hist
    }

    /// Put the owned particles (no ghosts yet) in the storage order asked for,
    /// their Gear rows with them: in id order always (a merge keeps it), along
    /// the curve or shuffled when `reorder_now` says so.
    fn reorder(&mut self, p: &mut Particles, gear: &mut GearState) {
        let now = std::mem::replace(&mut self.reorder_now, false);
        if !now && self.order != StorageOrder::Id {
            return;
        }
        let perm = match self.order {
            StorageOrder::Hilbert => crate::order::hilbert_order(p),
            StorageOrder::Cells => crate::order::cell_order(p, self.range),
            StorageOrder::Shuffled => {
                self.reorders += 1;
                crate::order::shuffled_order(p.len(), self.reorders ^ ((self.rank() as u64) << 40))
            }
            StorageOrder::Id => {
                if p.id.windows(2).all(|w| w[0] < w[1]) {
                    return;
                }
                let mut perm: Vec<usize> = (0..p.len()).collect();
                perm.sort_unstable_by_key(|&i| p.id[i]);
                perm
            }
        };
        if perm.iter().enumerate().all(|(k, &i)| k == i) {
            return;
        }
        let rows: Vec<Vec<Vec3>> = perm.iter().map(|&i| gear.get(i)).collect();
        p.permute(&perm);
        gear.set_all(&rows);
    }
}

/// Merge the particles that stay with the arrivals (sorted by id here): in id
/// order where `by_id` (and the staying ones are), else the staying ones
/// moved down in place and the arrivals after them (no result depends on
/// the storage order; `reorder` sets it).
fn merge_arrivals(p: &mut Particles, gear: &mut GearState, dest: &[usize], me: usize, mut arrived: Vec<(Record, Vec<Vec3>)>, by_id: bool) {
    arrived.sort_by_key(|a| a.0.id);
    if !by_id {
        if dest.iter().any(|&d| d != me) {
            let keep: Vec<usize> = (0..p.len()).filter(|&i| dest[i] == me).collect();
            p.keep_places(&keep);
            gear.keep_places(&keep);
        }
        for (r, row) in &arrived {
            p.push_record(r);
            gear.push(row);
        }
        return;
    }
    let mut q = Particles::default();
    let mut rows: Vec<Vec<Vec3>> = Vec::new();
    let mut k = 0;
    for i in (0..p.len()).filter(|&i| dest[i] == me) {
        while k < arrived.len() && arrived[k].0.id < p.id[i] {
            q.push_record(&arrived[k].0);
            rows.push(std::mem::take(&mut arrived[k].1));
            k += 1;
        }
        q.push_record(&p.record(i));
        rows.push(gear.get(i));
    }
    for a in arrived[k..].iter_mut() {
        q.push_record(&a.0);
        rows.push(std::mem::take(&mut a.1));
    }
    *p = q;
    gear.set_all(&rows);
}
