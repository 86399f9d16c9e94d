//! Parallel runtime, one job per file: the communicator (`comm`, the only code
//! that calls MPI; serial and MPI behind one interface), the decomposition by
//! cutting planes (`decomp`), ghosts (`ghosts`), migration with contact
//! history (`migration`), dynamic load balancing (`balance`, a scheduled step),
//! gathers for output (`gather`) and the collectives that steer the run
//! (`collective`). Physics code sees only `Particles` with the owned particles
//! first and the ghosts after. With one rank every exchange is empty and every
//! collective returns its input, so the same code runs serially.
//!
//! Results do not depend on the number of ranks: every particle's contact
//! forces are summed in the order of its partners' global ids (the pair list is
//! sorted by ids), a pair across a boundary is evaluated identically on both
//! sides from bit-identical ghost copies, contact history is keyed by ids and
//! travels with migrating particles, and global sums (energies, wall loads,
//! discharged mass) are exact fixed-point sums.

mod balance;
mod collective;
pub use collective::agreed;
pub mod comm;
pub mod decomp;
mod gather;
mod ghosts;
mod migration;

pub use balance::{BalanceMode, BalanceSettings};
pub use ghosts::image_shifts;
pub use migration::Carried;
use comm::Comm;
use crate::dim::Vec3;
use decomp::Decomposition;
use serde::{Deserialize, Serialize};
use std::rc::Rc;

/// Where a rank's time goes (s), reported with `TALUS_PROFILE=1`; `compute_s`
/// and `comm_s` are reset at every output row (`ranks.csv`), the others are
/// totals over the run.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timers {
    /// Physics (integration, lists, forces) since the last output row.
    pub compute_s: f64,
    /// Communication since the last output row.
    pub comm_s: f64,
    /// Migration and ghost remaking at list rebuilds.
    pub migrate: f64,
    /// Neighbour-list builds.
    pub list_build: f64,
    /// Ghost refreshes (position, velocity, spin) between rebuilds.
    pub ghost_refresh: f64,
    /// The per-step agreement (rebuild, failure, signal).
    pub agree: f64,
    /// The exact sum of wall loads over ranks.
    pub wall_sums: f64,
    /// The force sweep (pairs, gather, walls).
    pub forces: f64,
    /// Both halves of the integrator.
    pub integrate: f64,
    /// The displacement check before each step (with the agreement of all ranks).
    pub check: f64,
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
    /// How much farther than `range` the ghosts of this build reach (m): the
    /// largest skin a particle has at this build beyond the case's
    /// ([`Parallel::skin_limit`]).
    pub ghost_extra: f64,
    /// Owned particles (local indices) each neighbour rank keeps as ghosts.
    send: Vec<(usize, Vec<u32>)>,
    /// The periodic image shift of each ghost in `send` (periodic domains only).
    send_img: Vec<Vec<[i32; 3]>>,
    /// Ghosts received from each neighbour rank, in the order they are stored.
    recv: Vec<(usize, usize)>,
    /// Periodic images of this rank's own particles kept as its ghosts (after
    /// the received ones): the owned particle and the image's shift.
    self_images: Vec<(u32, [i32; 3])>,
    /// The period along each axis (m; 0 where the domain is not periodic).
    pub period: Vec3,
    pub balance: BalanceSettings,
    /// Where this rank's time went (s).
    pub timers: Timers,
    check_compute_s: f64,
    check_steps: u64,
    /// Contacts evaluated in the last sweep (the work counter).
    pub evaluated: usize,
    pub rebalance_pending: bool,
    pub rebalances: u64,
    /// The signal that asked every rank to stop, agreed at the same step.
    pub stop: Option<i32>,
    /// How owned particles are ordered in storage after each migration.
    pub order: crate::order::StorageOrder,
    /// Storage reorders so far (seeds the `shuffled` order).
    reorders: u64,
    /// Remake the storage order at the next migration (then cleared).
    pub reorder_now: bool,
    /// The rank's threads, where it has more than one: on one rank, migration
    /// reads the contact history out of the list on them.
    pub pool: Option<std::sync::Arc<rayon::ThreadPool>>,
    /// Particles inserted on this rank (those its box owns), joining the owned
    /// ones at the next migration as arrivals do.
    pub inserted: Vec<crate::particles::Record>,
}

/// Every rank's items, in rank order, on every rank.
#[track_caller]
pub fn all_gather<T: Serialize + for<'a> Deserialize<'a>>(comm: &Comm, mine: &Vec<T>) -> Vec<T> {
    comm.all_gather_bytes(&bin(mine)).iter().flat_map(|b| unbin::<Vec<T>>(b)).collect()
}

fn bin<T: Serialize>(x: &T) -> Vec<u8> {
    bincode::serialize(x).expect("serialisable")
}

fn unbin<T: for<'a> Deserialize<'a>>(b: &[u8]) -> T {
    bincode::deserialize(b).expect("a message from another talus rank")
}

impl Parallel {
    pub fn new(comm: Rc<Comm>, dec: Decomposition, range: f64, balance: BalanceSettings) -> Parallel {
        Parallel {
            comm,
            dec,
            range,
            ghost_extra: 0.0,
            send: Vec::new(),
            send_img: Vec::new(),
            recv: Vec::new(),
            self_images: Vec::new(),
            period: Vec3::zeros(),
            balance,
            timers: Timers::default(),
            check_compute_s: 0.0,
            check_steps: 0,
            evaluated: 0,
            rebalance_pending: false,
            rebalances: 0,
            stop: None,
            order: Default::default(),
            reorders: 0,
            pool: None,
            reorder_now: true,
            inserted: Vec::new(),
        }
    }

    pub fn rank(&self) -> usize {
        self.comm.rank()
    }

    /// The largest skin the next build may give a particle, agreed by
    /// every rank (a collective where there are several; `speed` gives this
    /// rank's largest owned particle speed, asked for only then), and the
    /// ghosts made to reach that much farther. One rank alone (no ghosts, no
    /// periodic images): no limit but the rule's own.
    pub fn skin_limit(&mut self, rule: &crate::neighbor::SkinRule, skin: f64, speed: impl FnOnce() -> f64) -> f64 {
        if rule.per_speed == 0.0 || self.period != Vec3::zeros() {
            self.ghost_extra = 0.0;
            return skin;
        }
        if self.size() == 1 {
            self.ghost_extra = 0.0;
            return f64::INFINITY;
        }
        let mut v = [speed()];
        self.comm.max_f64(&mut v);
        let s = rule.of(skin, f64::INFINITY, v[0]);
        self.ghost_extra = s - skin;
        s
    }

    pub fn size(&self) -> usize {
        self.comm.size()
    }
}
