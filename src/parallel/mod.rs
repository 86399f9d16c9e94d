//! Parallel runtime: domain decomposition by cutting planes, ghost exchange,
//! particle migration with contact history, dynamic load balancing, and the
//! per-rank diagnostics. Physics code sees only `Particles` with the owned
//! particles first and the ghosts after; everything about other ranks is here
//! and in `comm`.
//!
//! Results do not depend on the number of ranks: every particle's contact
//! forces are summed in the order of its partners' global ids (the pair list is
//! sorted by ids), a pair across a boundary is evaluated identically on both
//! sides from bit-identical ghost copies, contact history is keyed by ids and
//! travels with migrating particles, and global sums (energies, wall loads,
//! discharged mass) are exact fixed-point sums.

pub mod comm;
pub mod decomp;

use crate::dim::Vec3;
use crate::integrate::GearState;
use crate::neighbor::{History, NeighborList};
use crate::particles::{Particles, Record};
use comm::Comm;
use decomp::Decomposition;
use serde::{Deserialize, Serialize};
use std::rc::Rc;
use std::time::Instant;

/// How subdomain loads are estimated for balancing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum BalanceMode {
    /// Static planes (equal particle counts at the start).
    Off,
    /// Load = particles owned.
    Count,
    /// Load = particles x measured compute time per particle (the paper's).
    #[default]
    Time,
    /// Load = particles + contacts evaluated.
    Contacts,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BalanceSettings {
    pub mode: BalanceMode,
    /// Rebalance when any subdomain's estimated load departs from the mean by more than this fraction.
    pub tolerance: f64,
    /// Steps between load checks.
    pub interval: u64,
}

/// Counters of one rank over an output interval.
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct RankCounters {
    pub owned: u64,
    pub ghosts: u64,
    pub contacts: u64,
    pub compute_s: f64,
    pub comm_s: f64,
}

pub struct Parallel {
    pub comm: Rc<Comm>,
    pub dec: Decomposition,
    /// Ghost range: largest interaction distance plus skin (m).
    pub range: f64,
    /// Owned particles (local indices) each neighbour rank keeps as ghosts.
    send: Vec<(usize, Vec<u32>)>,
    /// Ghosts received from each neighbour rank, in the order they are stored.
    recv: Vec<(usize, usize)>,
    pub balance: BalanceSettings,
    /// Compute and communication time since the last output row / balance check (s).
    pub compute_s: f64,
    pub comm_s: f64,
    check_compute_s: f64,
    check_steps: u64,
    /// Contacts evaluated in the last sweep (the work counter).
    pub evaluated: usize,
    pub rebalance_pending: bool,
    pub rebalances: u64,
    /// Seconds in: migration + ghosts, list builds, ghost refresh, the per-step
    /// agreement, the wall-load sum (reported with TALUS_PROFILE=1).
    pub prof: [f64; 5],
    /// The signal that asked every rank to stop, agreed at the same step.
    pub stop: Option<i32>,
}

fn bin<T: Serialize>(x: &T) -> Vec<u8> {
    bincode::serialize(x).expect("serialisable")
}

fn unbin<T: for<'a> Deserialize<'a>>(b: &[u8]) -> T {
    bincode::deserialize(b).expect("a message from another talus rank")
}

/// What migrates with a particle.
#[derive(Serialize, Deserialize, Default)]
struct Migration {
    recs: Vec<Record>,
    gear: Vec<Vec<Vec3>>,
    hist: History,
}

impl Parallel {
    pub fn new(comm: Rc<Comm>, dec: Decomposition, range: f64, balance: BalanceSettings) -> Parallel {
        Parallel {
            comm,
            dec,
            range,
            send: Vec::new(),
            recv: Vec::new(),
            balance,
            compute_s: 0.0,
            comm_s: 0.0,
            check_compute_s: 0.0,
            check_steps: 0,
            evaluated: 0,
            rebalance_pending: false,
            rebalances: 0,
            prof: [0.0; 5],
            stop: None,
        }
    }

    pub fn rank(&self) -> usize {
        self.comm.rank()
    }

    pub fn size(&self) -> usize {
        self.comm.size()
    }

    /// Keep, out of the full set of particles (every rank holds the same), the
    /// ones this rank owns; with their Gear derivatives and the history that
    /// involves them. Used at set-up and at a restart.
    pub fn take_own(&self, p: &mut Particles, gear: &mut GearState, hist: &mut History) {
        let me = self.rank();
        let keep: Vec<usize> = (0..p.len()).filter(|&i| self.dec.owner(&p.pos[i]) == me).collect();
        let rows: Vec<Vec<Vec3>> = keep.iter().map(|&i| gear.get(i)).collect();
        p.permute(&keep);
        gear.set_all(&rows);
        let ids = &p.id;
        let mine = |id: u64| ids.binary_search(&id).is_ok();
        hist.pairs.retain(|((a, b), _)| mine(*a) || mine(*b));
        hist.walls.retain(|((a, _, _), _)| mine(*a));
    }

    /// At a list rebuild: migrate the particles whose owner changed (left the
    /// box, or the planes moved) with their Gear derivatives and the contact
    /// history that involves them, then remake the ghosts. The history is read
    /// from the current list (local indices make the split cheap); returns the
    /// history the new list must use.
    pub fn migrate_from_list(&mut self, p: &mut Particles, gear: &mut GearState, nl: &NeighborList) -> History {
        let me = self.rank();
        if self.size() == 1 {
            return nl.take_history(p);
        }
        let n = p.owned();
        let dest: Vec<usize> = (0..n).map(|i| self.dec.owner(&p.pos[i])).collect();
        let mut out: Vec<Migration> = (0..self.size()).map(|_| Migration::default()).collect();
        let mut hist = History::default();
        let zero = Vec3::zeros();
        for (k, &(a, b)) in nl.pairs.iter().enumerate() {
            let h = nl.pair_hist[k];
            if h == zero {
                continue;
            }
            let (a, b) = (a as usize, b as usize);
            let e = ((p.id[a], p.id[b]), h);
            let da = (a < n).then(|| dest[a]);
            let db = (b < n).then(|| dest[b]);
            if da == Some(me) || db == Some(me) {
                hist.pairs.push(e);
            }
            if let Some(r) = da.filter(|&r| r != me) {
                out[r].hist.pairs.push(e);
            }
            if let Some(r) = db.filter(|&r| r != me && Some(r) != da) {
                out[r].hist.pairs.push(e);
            }
        }
        for i in 0..n.min(nl.wall_start.len().saturating_sub(1)) {
            for k in nl.wall_start[i] as usize..nl.wall_start[i + 1] as usize {
                let h = nl.wall_hist[k];
                if h != zero {
                    let (w, f) = nl.wall_feat[k];
                    let e = ((p.id[i], w, f), h);
                    if dest[i] == me {
                        hist.walls.push(e);
                    } else {
                        out[dest[i]].hist.walls.push(e);
                    }
                }
            }
        }
        // the list is in id order already; sorting is then a linear check
        hist.pairs.sort_unstable_by_key(|x| x.0);
        hist.walls.sort_unstable_by_key(|x| x.0);
        p.drop_ghosts();
        for i in 0..n {
            if dest[i] != me {
                out[dest[i]].recs.push(p.record(i));
                out[dest[i]].gear.push(gear.get(i));
            }
        }
        self.exchange_owned(p, gear, hist, out, &dest)
    }

    /// Migrate particles that left this rank's box (used at set-up and restart,
    /// with the history given keyed by ids), then rebuild the ghost layer.
    pub fn migrate(&mut self, p: &mut Particles, gear: &mut GearState, mut hist: History) -> History {
        let p_count = self.size();
        let me = self.rank();
        p.drop_ghosts();
        let n = p.len();
        let mut dest = vec![me; n];
        let mut out: Vec<Migration> = (0..p_count).map(|_| Migration::default()).collect();
        let mut leaving = std::collections::HashMap::new();
        for i in 0..n {
            let r = self.dec.owner(&p.pos[i]);
            dest[i] = r;
            if r != me {
                leaving.insert(p.id[i], r);
                out[r].recs.push(p.record(i));
                out[r].gear.push(gear.get(i));
            }
        }
        if p_count == 1 {
            self.make_ghosts(p);
            return hist;
        }
        // history entries go wherever one of their particles goes
        for e in &hist.pairs {
            let (a, b) = e.0;
            let ra = leaving.get(&a);
            let rb = leaving.get(&b);
            if let Some(&r) = ra {
                out[r].hist.pairs.push(*e);
            }
            if let Some(&r) = rb {
                if ra != Some(&r) {
                    out[r].hist.pairs.push(*e);
                }
            }
        }
        for e in &hist.walls {
            if let Some(&r) = leaving.get(&e.0 .0) {
                out[r].hist.walls.push(*e);
            }
        }
        // keep what still involves a particle owned here (owned ids are sorted)
        let ids = &p.id;
        let stays = |id: &u64| !leaving.contains_key(id) && ids.binary_search(id).is_ok();
        hist.pairs.retain(|e| stays(&e.0 .0) || stays(&e.0 .1));
        hist.walls.retain(|e| stays(&e.0 .0));
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
        let n = p.len();
        let moved = dest.iter().any(|&d| d != me);
        {
            let msgs: Vec<Vec<u8>> =
                out.iter().enumerate().map(|(r, m)| if r == me || m.recs.is_empty() { Vec::new() } else { bin(m) }).collect();
            let got = self.comm.exchange_bytes(&msgs);
            let mut arrived: Vec<(Record, Vec<Vec3>)> = Vec::new();
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
            if moved || !arrived.is_empty() {
                // merge the staying particles (in id order) with the arrivals (sorted by id)
                arrived.sort_by_key(|a| a.0.id);
                let mut q = Particles::default();
                let mut rows: Vec<Vec<Vec3>> = Vec::new();
                let mut k = 0;
                for i in (0..n).filter(|&i| dest[i] == me) {
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
                if !add.pairs.is_empty() || !add.walls.is_empty() {
                    add.normalise();
                    hist.merge(add);
                }
            }
        }
        self.make_ghosts(p);
        hist
    }

    /// Send copies of the owned particles within `range` of another rank's box
    /// to that rank; append the ones received as ghosts.
    fn make_ghosts(&mut self, p: &mut Particles) {
        self.send.clear();
        self.recv.clear();
        let p_count = self.size();
        if p_count == 1 {
            return;
        }
        let me = self.rank();
        let boxes: Vec<(Vec3, Vec3)> = (0..p_count).map(|r| self.dec.bounds(r)).collect();
        let (mlo, mhi) = boxes[me];
        let near: Vec<usize> = (0..p_count)
            .filter(|&r| {
                r != me && {
                    let (lo, hi) = boxes[r];
                    let mut d2 = 0.0;
                    for k in 0..3 {
                        let d = (lo[k] - mhi[k]).max(mlo[k] - hi[k]).max(0.0);
                        d2 += d * d;
                    }
                    d2.sqrt() < self.range
                }
            })
            .collect();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); p_count];
        for i in 0..p.owned() {
            let x = p.pos[i];
            for &r in &near {
                let (lo, hi) = boxes[r];
                let mut d2 = 0.0;
                for k in 0..3 {
                    let d = (lo[k] - x[k]).max(x[k] - hi[k]).max(0.0);
                    d2 += d * d;
                }
                if d2 < self.range * self.range {
                    lists[r].push(i as u32);
                }
            }
        }
        let msgs: Vec<Vec<u8>> = lists
            .iter()
            .map(|l| if l.is_empty() { Vec::new() } else { bin(&l.iter().map(|&i| p.record(i as usize)).collect::<Vec<_>>()) })
            .collect();
        let got = self.comm.exchange_bytes(&msgs);
        let mut ghosts = 0;
        for (r, m) in got.iter().enumerate() {
            if r == me || m.is_empty() {
                continue;
            }
            let recs: Vec<Record> = unbin(m);
            for rec in &recs {
                p.push_record(rec);
            }
            ghosts += recs.len();
            self.recv.push((r, recs.len()));
        }
        p.ghosts = ghosts;
        for (r, l) in lists.into_iter().enumerate() {
            if !l.is_empty() {
                self.send.push((r, l));
            }
        }
    }

    /// Refresh the ghosts' position, velocity and spin (every step the lists are not rebuilt).
    pub fn update_ghosts(&self, p: &mut Particles) {
        if self.size() == 1 {
            return;
        }
        let to: Vec<usize> = self.send.iter().map(|s| s.0).collect();
        let sends: Vec<Vec<f64>> = self
            .send
            .iter()
            .map(|(_, l)| {
                let mut b = Vec::with_capacity(9 * l.len());
                for &i in l {
                    let i = i as usize;
                    for v in [p.pos[i], p.vel[i], p.omega[i]] {
                        b.extend_from_slice(&[v.x, v.y, v.z]);
                    }
                }
                b
            })
            .collect();
        let from: Vec<usize> = self.recv.iter().map(|r| r.0).collect();
        let mut recvs: Vec<Vec<f64>> = self.recv.iter().map(|r| vec![0.0; 9 * r.1]).collect();
        self.comm.exchange_f64(&to, &sends, &from, &mut recvs);
        let mut g = p.owned();
        for b in &recvs {
            for c in b.chunks_exact(9) {
                p.pos[g] = Vec3::new(c[0], c[1], c[2]);
                p.vel[g] = Vec3::new(c[3], c[4], c[5]);
                p.omega[g] = Vec3::new(c[6], c[7], c[8]);
                g += 1;
            }
        }
    }

    /// One collective per step: whether any rank needs a list rebuild, and
    /// whether any rank has failed (then every rank gets every rank's message).
    /// A stop asked for by a signal on any rank (see `crate::signals`) is
    /// agreed on in the same collective and kept in `stop`.
    pub fn agree(&mut self, need: bool, error: Option<String>) -> (bool, Option<String>) {
        let signal = crate::signals::requested();
        if self.size() == 1 {
            self.stop = self.stop.or(signal);
            return (need, error);
        }
        let t = Instant::now();
        let mut v = [need as u8 as f64, error.is_some() as u8 as f64, signal.unwrap_or(0) as f64];
        self.comm.max_f64(&mut v);
        if v[2] > 0.0 && self.stop.is_none() {
            self.stop = Some(v[2] as i32);
        }
        let err = if v[1] > 0.0 {
            let me = self.rank();
            let p = self.size();
            let mine = error.map(|e| format!("rank {me} of {p}: {e}")).unwrap_or_default();
            let all = self.comm.all_gather_bytes(mine.as_bytes());
            let msgs: Vec<String> =
                all.iter().filter(|m| !m.is_empty()).map(|m| String::from_utf8_lossy(m).to_string()).collect();
            Some(msgs.join("; "))
        } else {
            None
        };
        self.comm_s += t.elapsed().as_secs_f64();
        (v[0] > 0.0, err)
    }

    /// Called once per step with the compute time of the step. Every
    /// `balance.interval` steps, compares the estimated loads; if any departs
    /// from the mean by more than the tolerance, moves the planes (the caller
    /// then migrates at a forced list rebuild).
    pub fn after_step(&mut self, p: &Particles, step_compute_s: f64) {
        self.check_compute_s += step_compute_s;
        self.check_steps += 1;
        if self.size() == 1 || self.balance.mode == BalanceMode::Off || self.check_steps < self.balance.interval {
            return;
        }
        let t = Instant::now();
        let owned = p.owned() as f64;
        let load = match self.balance.mode {
            BalanceMode::Off => unreachable!(),
            BalanceMode::Count => owned,
            BalanceMode::Time => self.check_compute_s,
            BalanceMode::Contacts => owned + self.evaluated as f64,
        };
        let p_count = self.size();
        let mut loads = vec![0.0; p_count];
        loads[self.rank()] = load;
        self.comm.sum_f64(&mut loads);
        let mean = loads.iter().sum::<f64>() / p_count as f64;
        let worst = loads.iter().map(|l| (l - mean).abs()).fold(0.0, f64::max);
        if mean > 0.0 && worst > self.balance.tolerance * mean {
            // weight per particle = this rank's load coefficient
            let c = if owned > 0.0 { load / owned } else { 0.0 };
            let w = vec![c; p.owned()];
            self.dec.fit(&self.comm, &p.pos[..p.owned()], &w);
            self.rebalance_pending = true;
            self.rebalances += 1;
        }
        self.check_compute_s = 0.0;
        self.check_steps = 0;
        self.comm_s += t.elapsed().as_secs_f64();
    }

    /// Make a result collective: if it is an error on any rank, it is an error
    /// on every rank (with every failing rank's message).
    pub fn collective<T>(&self, r: Result<T, crate::error::TalusError>) -> Result<T, crate::error::TalusError> {
        if self.size() == 1 {
            return r;
        }
        let mut v = [r.is_err() as u8 as f64];
        self.comm.max_f64(&mut v);
        if v[0] == 0.0 {
            return r;
        }
        let mine = match &r {
            Err(e) => format!("rank {} of {}: {e}", self.rank(), self.size()),
            Ok(_) => String::new(),
        };
        let all = self.comm.all_gather_bytes(mine.as_bytes());
        let msgs: Vec<String> = all.iter().filter(|m| !m.is_empty()).map(|m| String::from_utf8_lossy(m).to_string()).collect();
        Err(crate::error::TalusError::Run(msgs.join("; ")))
    }

    /// Planes for equal particle counts, from the full set of positions (every rank has the same).
    pub fn refit_all(&mut self, pos: &[Vec3]) {
        self.dec.fit(&Comm::Serial, pos, &vec![1.0; pos.len()]);
    }

    /// Every rank's counters since the last call (a collective); resets them.
    pub fn gather_counters(&mut self, p: &Particles) -> Vec<RankCounters> {
        let mine = RankCounters {
            owned: p.owned() as u64,
            ghosts: p.ghosts as u64,
            contacts: self.evaluated as u64,
            compute_s: self.compute_s,
            comm_s: self.comm_s,
        };
        self.compute_s = 0.0;
        self.comm_s = 0.0;
        self.comm.all_gather_bytes(&bin(&mine)).iter().map(|b| unbin(b)).collect()
    }

    /// Every rank's owned particle records (with Gear rows), sorted by id, on every rank.
    pub fn gather_all(&self, p: &Particles, gear: &GearState) -> (Vec<Record>, Vec<Vec<Vec3>>) {
        if self.size() == 1 {
            return ((0..p.owned()).map(|i| p.record(i)).collect(), (0..p.owned()).map(|i| gear.get(i)).collect());
        }
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
        if self.size() == 1 {
            return h;
        }
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
        let own = &p.id[..p.owned()];
        let mine: Vec<Record> = ids.iter().filter_map(|id| own.binary_search(id).ok().map(|i| p.record(i))).collect();
        let all: Vec<Record> = if self.size() == 1 {
            mine
        } else {
            self.comm.all_gather_bytes(&bin(&mine)).iter().flat_map(|b| unbin::<Vec<Record>>(b)).collect()
        };
        ids.iter().map(|id| all.iter().find(|r| r.id == *id).copied()).collect()
    }
}
