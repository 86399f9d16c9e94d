//! Gathers for output: counters, whole states (snapshots, checkpoints, the
//! state hash), history, tracked particles. Every rank gets the result.

use super::{Parallel, RankCounters};
use crate::dim::Vec3;
use crate::integrate::GearState;
use crate::neighbor::History;
use crate::particles::{Particles, Record};

impl Parallel {
    /// Every rank's counters since the last call (a collective); resets them.
    pub fn gather_counters(&mut self, p: &Particles) -> Vec<RankCounters> {
        let mine = RankCounters {
            owned: p.owned() as u64,
            ghosts: p.ghosts as u64,
            contacts: self.evaluated as u64,
            compute_s: self.timers.compute_s,
            comm_s: self.timers.comm_s,
        };
        self.timers.compute_s = 0.0;
        self.timers.comm_s = 0.0;
        self.comm.all_gather_values(mine)
    }

    /// Every rank's owned particles as one `Particles` in order of id (with
    /// Gear rows, none where Gear has not started), on every rank: what a
    /// checkpoint holds, a snapshot and `final.csv` write and the state hash
    /// reads. Each rank puts its own in order of id straight into new arrays,
    /// so one rank's come back as they are made: one copy of the particles;
    /// several ranks' runs are appended and sorted (ids are unique).
    pub fn gather_particles(&self, p: &Particles, gear: &GearState) -> (Particles, Vec<Vec<Vec3>>) {
        let order = id_order(p);
        let mine = (p.selected(&order), gear_rows(gear, &order));
        let parts = self.comm.all_gather_values(mine);
        let (mut all, mut rows) = parts
            .into_iter()
            .reduce(|(mut a, mut g), (b, g2)| {
                a.append(b);
                g.extend(g2);
                (a, g)
            })
            .unwrap_or_default();
        if !all.id.is_sorted() {
            let mut order: Vec<usize> = (0..all.len()).collect();
            order.sort_unstable_by_key(|&i| all.id[i]);
            all.permute(&order);
            if rows.len() == order.len() {
                rows = order.iter().map(|&i| std::mem::take(&mut rows[i])).collect();
            }
        }
        (all, rows)
    }

    /// The whole history, on every rank (pairs evaluated on two ranks appear once).
    pub fn gather_history(&self, h: History) -> History {
        let mut all = self
            .comm
            .all_gather_values(h)
            .into_iter()
            .reduce(|mut a, b| {
                a.pairs.extend(b.pairs);
                a.walls.extend(b.walls);
                a
            })
            .unwrap_or_default();
        all.normalise();
        all
    }

    /// Records of the given ids (owned by any rank), in the order asked, on every rank.
    pub fn gather_ids(&self, p: &Particles, ids: &[u64]) -> Vec<Option<Record>> {
        // storage is in spatial order, not id order: a scan (few ids are asked for)
        let own = &p.id[..p.owned()];
        let mine: Vec<Record> = ids.iter().filter_map(|id| own.iter().position(|x| x == id).map(|i| p.record(i))).collect();
        let all: Vec<Record> = super::all_gather(&self.comm, &mine);
        ids.iter().map(|id| all.iter().find(|r| r.id == *id).copied()).collect()
    }
}

/// The places of the owned particles in order of their ids.
fn id_order(p: &Particles) -> Vec<usize> {
    let mut order: Vec<usize> = (0..p.owned()).collect();
    order.sort_unstable_by_key(|&i| p.id[i]);
    order
}

/// The Gear rows of the particles at `order` (none where Gear has not started).
fn gear_rows(gear: &GearState, order: &[usize]) -> Vec<Vec<Vec3>> {
    if gear.initialised { order.iter().map(|&i| gear.get(i)).collect() } else { Vec::new() }
}
