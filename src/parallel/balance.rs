//! Dynamic load balancing (the hopper paper's moving planes), a scheduled step.
//!
//! Every `interval` steps each rank's load is estimated by the mode (`time`:
//! the compute time measured over the interval, i.e. particles times the
//! rank's load coefficient; `count`: particles; `contacts`: particles plus
//! contacts evaluated; `off`: static planes). When any load departs from the
//! mean by more than `tolerance`, the planes move so that the estimated loads
//! are equal: every particle carries its rank's coefficient (load / particles)
//! as weight, weighted histograms along each cut axis are summed over ranks
//! and the planes put at equal shares; the caller then rebuilds with migration.
//!
//! Limits: the estimate assumes the cost per particle is uniform inside a rank;
//! load is measured over the past interval, so a fast-changing flow lags by one
//! interval; the planes reach the equal-load position in one pass (no damping);
//! with one rank the single load is the mean and nothing ever moves.

use super::Parallel;
use crate::particles::Particles;
use serde::{Deserialize, Serialize};

/// How subdomain loads are estimated for balancing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema)]
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

impl Parallel {
    /// Called once per step with the compute time of the step. Every
    /// `balance.interval` steps, compares the estimated loads; if any departs
    /// from the mean by more than the tolerance, moves the planes (the caller
    /// then migrates at a forced list rebuild).
    pub fn after_step(&mut self, p: &Particles, step_compute_s: f64) {
        self.check_compute_s += step_compute_s;
        self.check_steps += 1;
        if self.check_steps < self.balance.interval {
            return;
        }
        let owned = p.owned() as f64;
        let load = match self.balance.mode {
            BalanceMode::Off => {
                self.check_steps = 0;
                return;
            }
            BalanceMode::Count => owned,
            BalanceMode::Time => self.check_compute_s,
            BalanceMode::Contacts => owned + self.evaluated as f64,
        };
        let t = std::time::Instant::now();
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
        self.timers.comm_s += t.elapsed().as_secs_f64();
    }
}
