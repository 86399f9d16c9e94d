//! Rigid clumps in 2D: the drag paper's dumbbells (two identical discs joined
//! at their contact point C, paper eqs. 3-6). A clump's state is the position
//! and velocity of C, its angle theta (the line through the member centres) and
//! its spin about z. Contacts are found and evaluated per member, like any
//! particle (members of one clump never touch each other); the members' forces
//! and torques are summed onto the clump, with the torque of each member force
//! about C; the clump is integrated (velocity Verlet, as the particles) and the
//! members are placed rigidly: x = x_C +- h e(theta), v = v_C + omega k x (x - x_C).
//! Serial runs only (a clump's members must live on one rank).

use crate::dim::Vec3;
use crate::particles::Particles;
use serde::{Deserialize, Serialize};

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Clumps {
    /// Local indices of the two members.
    pub members: Vec<[usize; 2]>,
    pub pos: Vec<Vec3>,
    pub vel: Vec<Vec3>,
    pub angle: Vec<f64>,
    pub omega: Vec<f64>,
    /// Distance from C to each member centre (m).
    pub half: Vec<f64>,
    pub mass: Vec<f64>,
    /// Moment of inertia about C, about z (kg m^2).
    pub inertia: Vec<f64>,
}

impl Clumps {
    pub fn is_empty(&self) -> bool {
        self.members.is_empty()
    }

    /// Clumps from pairs of member indices (their current positions fix C and
    /// theta; their momenta give v_C and omega). Marks the members in `p.clump`.
    pub fn new(p: &mut Particles, pairs: &[[usize; 2]]) -> Clumps {
        let mut c = Clumps::default();
        for (k, &[a, b]) in pairs.iter().enumerate() {
            p.clump[a] = k as u32 + 1;
            p.clump[b] = k as u32 + 1;
            let d = p.pos[a] - p.pos[b];
            let (ma, mb) = (p.mass[a], p.mass[b]);
            c.members.push([a, b]);
            c.pos.push((p.pos[a] + p.pos[b]) * 0.5);
            c.vel.push((p.vel[a] * ma + p.vel[b] * mb) / (ma + mb));
            c.angle.push(d.y.atan2(d.x));
            c.omega.push(0.5 * (p.omega[a].z + p.omega[b].z));
            c.half.push(0.5 * d.norm());
            c.mass.push(0.0);
            c.inertia.push(0.0);
        }
        c.refresh_mass(p);
        c.place(p);
        c
    }

    /// Mass and inertia about C from the members (after their radii changed).
    pub fn refresh_mass(&mut self, p: &Particles) {
        for k in 0..self.members.len() {
            let [a, b] = self.members[k];
            let h2 = self.half[k] * self.half[k];
            self.mass[k] = p.mass[a] + p.mass[b];
            self.inertia[k] = 1.0 / p.inv_inertia[a] + 1.0 / p.inv_inertia[b] + (p.mass[a] + p.mass[b]) * h2;
        }
    }

    /// Put the members where the clump says (positions, velocities, spins).
    pub fn place(&self, p: &mut Particles) {
        for k in 0..self.members.len() {
            let e = Vec3::new(self.angle[k].cos(), self.angle[k].sin(), 0.0) * self.half[k];
            let w = Vec3::new(0.0, 0.0, self.omega[k]);
            for (i, r) in [(self.members[k][0], e), (self.members[k][1], -e)] {
                p.pos[i] = self.pos[k] + r;
                p.vel[i] = self.vel[k] + w.cross(&r);
                p.omega[i] = w;
            }
        }
    }

    /// Force and torque about C (z) on clump k from its members.
    fn load(&self, p: &Particles, k: usize) -> (Vec3, f64) {
        let mut f = Vec3::zeros();
        let mut t = 0.0;
        for &i in &self.members[k] {
            f += p.force[i];
            t += p.torque[i].z + (p.pos[i] - self.pos[k]).cross(&p.force[i]).z;
        }
        (Vec3::new(f.x, f.y, 0.0), t)
    }

    /// Velocity Verlet, first half: half kick and drift; then place the members.
    pub fn first_half(&mut self, p: &mut Particles, dt: f64) {
        for k in 0..self.members.len() {
            let (f, t) = self.load(p, k);
            self.vel[k] += f * (0.5 * dt / self.mass[k]);
            self.omega[k] += t * 0.5 * dt / self.inertia[k];
            self.pos[k] += self.vel[k] * dt;
            self.angle[k] += self.omega[k] * dt;
        }
        self.place(p);
    }

    /// Velocity Verlet, second half kick; then the members' velocities.
    pub fn second_half(&mut self, p: &mut Particles, dt: f64) {
        for k in 0..self.members.len() {
            let (f, t) = self.load(p, k);
            self.vel[k] += f * (0.5 * dt / self.mass[k]);
            self.omega[k] += t * 0.5 * dt / self.inertia[k];
        }
        self.place(p);
    }
}
