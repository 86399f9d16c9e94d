//! Ghosts: after each rebuild, every owned particle within `range` (largest
//! interaction distance plus skin) of another rank's box is sent to that rank
//! (direct sends to any rank in range, so thin boxes and grids need no
//! multi-hop forwarding); every other step only the same ghosts' position,
//! velocity and spin travel, by non-blocking sends of sizes both sides know.
//! With one rank there is no other box, so there are no ghosts.

use super::{bin, unbin, Parallel};
use crate::dim::Vec3;
use crate::particles::{Particles, Record};

/// Distance from a point or box to a box (zero inside or overlapping).
fn gap(lo: &Vec3, hi: &Vec3, plo: &Vec3, phi: &Vec3) -> f64 {
    let mut d2 = 0.0;
    for k in 0..3 {
        let d = (lo[k] - phi[k]).max(plo[k] - hi[k]).max(0.0);
        d2 += d * d;
    }
    d2.sqrt()
}

impl Parallel {
    /// Send copies of the owned particles within `range` of another rank's box
    /// to that rank; append the ones received as ghosts.
    pub(super) fn make_ghosts(&mut self, p: &mut Particles) {
        self.send.clear();
        self.recv.clear();
        let p_count = self.size();
        let me = self.rank();
        let boxes: Vec<(Vec3, Vec3)> = (0..p_count).map(|r| self.dec.bounds(r)).collect();
        let (mlo, mhi) = boxes[me];
        let near: Vec<usize> =
            (0..p_count).filter(|&r| r != me && gap(&boxes[r].0, &boxes[r].1, &mlo, &mhi) < self.range).collect();
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); p_count];
        if !near.is_empty() {
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
}
