//! Particle storage: structure of arrays, dense local indices, stable global ids.
//!
//! Local order is the order of increasing global id (the lattice generator and
//! the CSV loader assign ids so that neighbours in space have close ids). Later,
//! with MPI, owned particles come first and ghosts after.

use crate::dim::Vec3;
use serde::{Deserialize, Serialize};

/// Spheres (3D) or discs (2D), one entry per particle in each array.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Particles {
    /// Stable global id, unique in the run.
    pub id: Vec<u64>,
    pub pos: Vec<Vec3>,
    pub vel: Vec<Vec3>,
    /// Angular velocity (rad/s).
    pub omega: Vec<Vec3>,
    pub force: Vec<Vec3>,
    pub torque: Vec<Vec3>,
    pub radius: Vec<f64>,
    pub mass: Vec<f64>,
    pub inv_mass: Vec<f64>,
    /// 1 / I, with I = 2/5 m r^2 for a sphere.
    pub inv_inertia: Vec<f64>,
    /// Material index into the case's material list.
    pub material: Vec<u16>,
}

/// One particle as read from input, before it enters the arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleInit {
    pub id: u64,
    pub pos: Vec3,
    pub vel: Vec3,
    pub omega: Vec3,
    pub radius: f64,
}

impl Particles {
    pub fn len(&self) -> usize {
        self.id.len()
    }
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// Add a sphere of the given density and material index.
    pub fn push_sphere(&mut self, p: &ParticleInit, density: f64, material: u16) {
        let mass = density * 4.0 / 3.0 * std::f64::consts::PI * p.radius.powi(3);
        let inertia = 0.4 * mass * p.radius * p.radius;
        self.id.push(p.id);
        self.pos.push(p.pos);
        self.vel.push(p.vel);
        self.omega.push(p.omega);
        self.force.push(Vec3::zeros());
        self.torque.push(Vec3::zeros());
        self.radius.push(p.radius);
        self.mass.push(mass);
        self.inv_mass.push(1.0 / mass);
        self.inv_inertia.push(1.0 / inertia);
        self.material.push(material);
    }

    /// Sort every array by global id (stable local order).
    pub fn sort_by_id(&mut self) {
        let mut perm: Vec<usize> = (0..self.len()).collect();
        perm.sort_by_key(|&i| self.id[i]);
        macro_rules! permute {
            ($($f:ident),*) => { $( self.$f = perm.iter().map(|&i| self.$f[i]).collect(); )* };
        }
        permute!(id, pos, vel, omega, force, torque, radius, mass, inv_mass, inv_inertia, material);
    }

    /// The particles as input records (for writing a cloud file).
    pub fn to_inits(&self) -> Vec<ParticleInit> {
        (0..self.len())
            .map(|i| ParticleInit { id: self.id[i], pos: self.pos[i], vel: self.vel[i], omega: self.omega[i], radius: self.radius[i] })
            .collect()
    }

    /// Local index of a global id (linear search; used for set-up and probes only).
    pub fn index_of(&self, id: u64) -> Option<usize> {
        self.id.iter().position(|&x| x == id)
    }

    /// Total kinetic energy, translational plus rotational (J).
    pub fn kinetic_energy(&self) -> f64 {
        let mut e = 0.0;
        for i in 0..self.len() {
            e += 0.5 * self.mass[i] * self.vel[i].norm_squared()
                + 0.5 / self.inv_inertia[i] * self.omega[i].norm_squared();
        }
        e
    }

    /// Potential energy in gravity g relative to the origin (J).
    pub fn potential_energy(&self, g: Vec3) -> f64 {
        let mut e = 0.0;
        for i in 0..self.len() {
            e -= self.mass[i] * g.dot(&self.pos[i]);
        }
        e
    }

    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }
}
