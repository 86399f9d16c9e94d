//! Time integrators, both with rotation.
//!
//! - `verlet`: velocity Verlet (LIGGGHTS `fix nve/sphere`): half kick, drift,
//!   forces, half kick. Second order.
//! - `gear`: the 5th-order Gear predictor-corrector of the hopper paper (Allen and
//!   Tildesley, Computer Simulation of Liquids, appendix E): six scaled
//!   derivatives of position (second-order equation, corrector coefficients
//!   3/20, 251/360, 1, 11/18, 1/6, 1/60 for velocity-dependent forces) and six of
//!   angular velocity (first-order equation, 95/288, 1, 25/24, 35/72, 5/48, 1/120).

use crate::dim::{Dimension, Vec3};
use crate::particles::Particles;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default, schemars::JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorKind {
    #[default]
    Verlet,
    Gear,
}

/// Particles a thread integrates at once.
const CHUNK: usize = 4096;

/// Velocity Verlet: first half (kick and drift), blocks of particles in
/// parallel on the current thread pool (each particle's update is its own;
/// `grain`: fewest blocks a thread takes, `usize::MAX` for no split).
pub fn verlet_first(p: &mut Particles, dt: f64, dim: Dimension, grain: usize) {
    let h = 0.5 * dt;
    let n = p.owned();
    let (force, torque, inv_mass, inv_inertia) = (&p.force, &p.torque, &p.inv_mass, &p.inv_inertia);
    p.vel[..n].par_chunks_mut(CHUNK).zip(p.omega[..n].par_chunks_mut(CHUNK)).zip(p.pos[..n].par_chunks_mut(CHUNK)).enumerate().with_min_len(grain).for_each(
        |(c, ((vel, omega), pos))| {
            let base = c * CHUNK;
            for j in 0..vel.len() {
                let i = base + j;
                vel[j] = dim.project_linear(vel[j] + force[i] * (h * inv_mass[i]));
                omega[j] = dim.project_angular(omega[j] + torque[i] * (h * inv_inertia[i]));
                pos[j] += vel[j] * dt;
            }
        },
    );
    if dim == Dimension::Two {
        // orientation (ellipses); spin is about z only
        for i in 0..p.owned() {
            p.angle[i] += p.omega[i].z * dt;
        }
    }
}

/// Velocity Verlet: second half kick, after the forces (blocks of particles in parallel).
pub fn verlet_second(p: &mut Particles, dt: f64, dim: Dimension, grain: usize) {
    let h = 0.5 * dt;
    let n = p.owned();
    let (force, torque, inv_mass, inv_inertia) = (&p.force, &p.torque, &p.inv_mass, &p.inv_inertia);
    p.vel[..n].par_chunks_mut(CHUNK).zip(p.omega[..n].par_chunks_mut(CHUNK)).enumerate().with_min_len(grain).for_each(|(c, (vel, omega))| {
        let base = c * CHUNK;
        for j in 0..vel.len() {
            let i = base + j;
            vel[j] = dim.project_linear(vel[j] + force[i] * (h * inv_mass[i]));
            omega[j] = dim.project_angular(omega[j] + torque[i] * (h * inv_inertia[i]));
        }
    });
}

/// Scaled derivatives for Gear: r[k] = dt^k / k! d^k x / dt^k, w[k] likewise for omega.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct GearState {
    pub r: [Vec<Vec3>; 6],
    pub w: [Vec<Vec3>; 6],
    pub initialised: bool,
}

const GEAR_X: [f64; 6] = [3.0 / 20.0, 251.0 / 360.0, 1.0, 11.0 / 18.0, 1.0 / 6.0, 1.0 / 60.0];
const GEAR_W: [f64; 6] = [95.0 / 288.0, 1.0, 25.0 / 24.0, 35.0 / 72.0, 5.0 / 48.0, 1.0 / 120.0];
/// Binomial coefficients C(j, i) for the Taylor predictor.
const BINOM: [[f64; 6]; 6] = [
    [1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
    [0.0, 1.0, 2.0, 3.0, 4.0, 5.0],
    [0.0, 0.0, 1.0, 3.0, 6.0, 10.0],
    [0.0, 0.0, 0.0, 1.0, 4.0, 10.0],
    [0.0, 0.0, 0.0, 0.0, 1.0, 5.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, 1.0],
];

impl GearState {
    /// One particle's derivatives (12 vectors), for migration and checkpoints.
    pub fn get(&self, i: usize) -> Vec<Vec3> {
        if !self.initialised {
            return Vec::new();
        }
        (0..6).map(|k| self.r[k][i]).chain((0..6).map(|k| self.w[k][i])).collect()
    }

    /// Rebuild the arrays from per-particle derivatives (as `get` returns them).
    pub fn set_all(&mut self, rows: &[Vec<Vec3>]) {
        if !self.initialised {
            return;
        }
        for k in 0..6 {
            self.r[k] = rows.iter().map(|d| d[k]).collect();
            self.w[k] = rows.iter().map(|d| d[6 + k]).collect();
        }
    }

    /// Keep only the rows at places `keep` (increasing), as
    /// `Particles::keep_places`.
    pub fn keep_places(&mut self, keep: &[usize]) {
        if !self.initialised {
            return;
        }
        for a in self.r.iter_mut().chain(self.w.iter_mut()) {
            for (j, &i) in keep.iter().enumerate() {
                a[j] = a[i];
            }
            a.truncate(keep.len());
        }
    }

    /// Add one particle's derivatives at the end (as `get` returns them:
    /// every particle has them once they are set, as a case with Gear
    /// inserts none; `set_all` takes the rows alike).
    pub fn push(&mut self, row: &[Vec3]) {
        if !self.initialised {
            return;
        }
        for k in 0..6 {
            self.r[k].push(row[k]);
            self.w[k].push(row[6 + k]);
        }
    }

    /// Set the derivatives from the particles' state and current forces.
    pub fn init(&mut self, p: &Particles, dt: f64, dim: Dimension) {
        let n = p.owned();
        for k in 0..6 {
            self.r[k] = vec![Vec3::zeros(); n];
            self.w[k] = vec![Vec3::zeros(); n];
        }
        for i in 0..n {
            self.r[0][i] = p.pos[i];
            self.r[1][i] = p.vel[i] * dt;
            self.r[2][i] = dim.project_linear(p.force[i] * (0.5 * dt * dt * p.inv_mass[i]));
            self.w[0][i] = p.omega[i];
            self.w[1][i] = dim.project_angular(p.torque[i] * (dt * p.inv_inertia[i]));
        }
        self.initialised = true;
    }

    /// Predictor: Taylor expansion of every derivative; writes the predicted
    /// position, velocity and spin into the particle arrays.
    pub fn predict(&mut self, p: &mut Particles, dt: f64) {
        for arr in [&mut self.r, &mut self.w] {
            for i in 0..p.owned() {
                let mut v = [Vec3::zeros(); 6];
                for k in 0..6 {
                    v[k] = arr[k][i];
                }
                for k in 0..5 {
                    let mut s = v[k];
                    for j in k + 1..6 {
                        s += v[j] * BINOM[k][j];
                    }
                    arr[k][i] = s;
                }
            }
        }
        let inv = 1.0 / dt;
        for i in 0..p.owned() {
            p.pos[i] = self.r[0][i];
            p.vel[i] = self.r[1][i] * inv;
            p.omega[i] = self.w[0][i];
        }
    }

    /// Corrector: compare the predicted acceleration with the one from the forces.
    pub fn correct(&mut self, p: &mut Particles, dt: f64, dim: Dimension) {
        let inv = 1.0 / dt;
        for i in 0..p.owned() {
            let dx = dim.project_linear(p.force[i] * (0.5 * dt * dt * p.inv_mass[i]) - self.r[2][i]);
            for k in 0..6 {
                self.r[k][i] += dx * GEAR_X[k];
            }
            let dw = dim.project_angular(p.torque[i] * (dt * p.inv_inertia[i]) - self.w[1][i]);
            for k in 0..6 {
                self.w[k][i] += dw * GEAR_W[k];
            }
            p.pos[i] = self.r[0][i];
            p.vel[i] = self.r[1][i] * inv;
            p.omega[i] = self.w[0][i];
        }
    }
}
