//! Gathers for output: counters, whole states (snapshots, checkpoints, the
//! state hash), history, tracked particles. Every rank gets the result.

use super::{bin, unbin, Parallel, RankCounters};
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
        self.comm.all_gather_bytes(&bin(&mine)).iter().map(|b| unbin(b)).collect()
    }

    /// Every rank's owned particle records (with Gear rows), sorted by id, on every rank.
    pub fn gather_all(&self, p: &Particles, gear: &GearState) -> (Vec<Record>, Vec<Vec<Vec3>>) {
        let mine: (Vec<Record>, Vec<Vec<Vec3>>) =
            ((0..p.owned()).map(|i| p.record(i)).collect(), (0..p.owned()).map(|i| gear.get(i)).collect());
        let mut recs = Vec::new();
        let mut rows = Vec::new();
        for b in self.comm.all_gather_bytes(&bin(&mine)) {
            let (r, g): (Vec<Record>, Vec<Vec<Vec3>>) = unbin(&b);
            recs.extend(r);
            rows.extend(g);
        }
        let mut order: Vec<usize> = (0..recs.len()).collect();
        order.sort_by_key(|&i| recs[i].id);
        let recs2 = order.iter().map(|&i| recs[i]).collect();
        let rows2 = if rows.len() == recs.len() { order.iter().map(|&i| rows[i].clone()).collect() } else { Vec::new() };
        (recs2, rows2)
    }

    /// The whole history, on every rank (pairs evaluated on two ranks appear once).
    pub fn gather_history(&self, h: History) -> History {
        let mut all = History::default();
        for b in self.comm.all_gather_bytes(&bin(&h)) {
            let x: History = unbin(&b);
            all.pairs.extend(x.pairs);
            all.walls.extend(x.walls);
        }
        all.normalise();
        all
    }

    /// Records of the given ids (owned by any rank), in the order asked, on every rank.
    pub fn gather_ids(&self, p: &Particles, ids: &[u64]) -> Vec<Option<Record>> {
        // storage is in spatial order, not id order: a scan (few ids are asked for)
        let own = &p.id[..p.owned()];
        let mine: Vec<Record> = ids.iter().filter_map(|id| own.iter().position(|x| x == id).map(|i| p.record(i))).collect();
        let all: Vec<Record> = self.comm.all_gather_bytes(&bin(&mine)).iter().flat_map(|b| unbin::<Vec<Record>>(b)).collect();
        ids.iter().map(|id| all.iter().find(|r| r.id == *id).copied()).collect()
    }
}
