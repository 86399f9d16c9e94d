//! The figures a run reports in `summary.json`, computed from the run itself:
//! single-collision figures (restitution, contact duration, peak overlap and
//! force, tangential rebound, spin) and hopper figures (end-of-fill wall loads,
//! discharge rate by the 20-80% least-squares fit).

use crate::case::{AnalysisSection, Case};
use crate::dim::Vec3;
use crate::error::TalusError;
use crate::particles::{Particles, Record};
use crate::sim::State;
use crate::walls::{Shape, Wall};
use serde::{Deserialize, Serialize};
use serde_json::{json, Map, Value};
use std::collections::VecDeque;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum Analysis {
    None,
    Collision(Collision),
    Hopper(Hopper),
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Collision {
    /// Global ids of the particle and its partner.
    particle: u64,
    partner: Option<u64>,
    wall: Option<usize>,
    /// Normal (from partner to particle) and tangential direction fixed at t = 0
    /// (the frame of the tangential figures; see `tangential_frame`).
    n: Vec3,
    t: Vec3,
    v_in: Vec3,
    prev: Option<(f64, f64)>,
    start: Option<f64>,
    end: Option<f64>,
    max_overlap: f64,
    max_force: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Hopper {
    walls: Vec<usize>,
    gate: usize,
    fill: String,
    window: f64,
    /// (time, hopper walls load, gate load) over the last `window` seconds, downward positive.
    recent: VecDeque<(f64, f64, f64)>,
    fill_end: Option<(f64, f64, f64)>,
    discharge_start: Option<f64>,
    /// (time since discharge start, mass below z = 0).
    discharged: Vec<(f64, f64)>,
    total_mass: f64,
    total_weight: f64,
}

fn relative_velocity(p: &Particles, i: usize, j: Option<usize>) -> Vec3 {
    p.vel[i] - j.map(|j| p.vel[j]).unwrap_or_else(Vec3::zeros)
}

/// The collision's particle and partner from the records `Analysis::ids` asked for.
fn pair_of(tracked: &[Option<Record>]) -> (Record, Option<Record>) {
    let a = tracked[0].expect("the collision particle exists on some rank");
    (a, tracked.get(1).copied().flatten())
}

/// The tangential direction t of a collision's figures, fixed at t = 0 from the
/// relative motion of the particle `i` and its partner `j` (none: a wall) along
/// the normal `n` (from the partner or wall to the particle):
///
/// 1. the incoming tangential velocity v_t = v - (v.n) n, v = v_i - v_j, if not zero;
/// 2. else the slip of the contact point due to spin, the tangential velocity
///    w_i x (-r_i n) - w_j x (r_j n) (the contact point is -r_i n from the
///    particle's centre and r_j n from the partner's), if not zero;
/// 3. else none (t = 0: the tangential figures are 0).
///
/// `tangential_rebound_m_s` is then v_out.t and `spin_rad_s` is w_i.(n x t): a
/// positive spin rolls the particle along +t. For a spinning particle dropped
/// normally (case 2), the contact point slips along +t, friction pushes the
/// particle along -t and brakes the spin: both figures come out negative.
fn tangential_frame(p: &Particles, i: usize, j: Option<usize>, n: Vec3) -> Vec3 {
    let v = relative_velocity(p, i, j);
    let vt = v - n * v.dot(&n);
    if vt.norm() > 0.0 {
        return vt.normalize();
    }
    let mut slip = p.omega[i].cross(&(-n * p.radius[i]));
    if let Some(j) = j {
        slip -= p.omega[j].cross(&(n * p.radius[j]));
    }
    let slip = slip - n * slip.dot(&n);
    if slip.norm() > 0.0 { slip.normalize() } else { Vec3::zeros() }
}

impl Analysis {
    pub fn new(case: &Case, p: &Particles, walls: &[Wall]) -> Result<Analysis, TalusError> {
        let path = case.path.display();
        let wall_index = |name: &str, key: &str| {
            walls.iter().position(|w| w.name == name).ok_or_else(|| {
                TalusError::Input(format!("{path}: analysis.{key} = \"{name}\": no wall of that name"))
            })
        };
        let particle_index = |id: u64, key: &str| {
            p.index_of(id)
                .ok_or_else(|| TalusError::Input(format!("{path}: analysis.{key} = {id}: no particle with that id")))
        };
        Ok(match &case.analysis {
            None => Analysis::None,
            Some(AnalysisSection::Drag { wall, window }) => {
                let w = wall_index(wall, "wall")?;
                // it moves from the start, or from a phase's move on
                let moved_by_phase =
                    case.phases.iter().flat_map(|p| &p.moves).any(|m| m.wall == *wall && Vec3::from(m.velocity) != Vec3::zeros());
                if Vec3::from(case.walls[w].velocity) == Vec3::zeros() && !moved_by_phase {
                    return Err(TalusError::Input(format!("{path}: analysis.wall = \"{wall}\": the wall does not move, so it feels no drag")));
                }
                if !(window[0] >= 0.0 && window[1] > window[0]) {
                    return Err(TalusError::Input(format!("{path}: analysis.window = {window:?}: must be [from, to] displacements (m), 0 <= from < to")));
                }
                Analysis::None
            }
            Some(AnalysisSection::Pile { profile, .. }) => {
                if profile != "radial" && profile != "x" {
                    return Err(TalusError::Input(format!("{path}: analysis.profile = \"{profile}\": must be \"radial\" or \"x\"")));
                }
                if !case.output.final_state {
                    return Err(TalusError::Input(format!("{path}: analysis.kind = \"pile\": needs output.final_state = true (the angle of repose is measured from final.csv)")));
                }
                Analysis::None
            }
            Some(AnalysisSection::Drum { wall, window }) => {
                let w = wall_index(wall, "wall")?;
                let turns = case.walls[w].rotation.is_some()
                    || case.phases.iter().flat_map(|p| &p.moves).any(|m| m.wall == *wall && m.rotation.is_some());
                if !turns {
                    return Err(TalusError::Input(format!("{path}: analysis.wall = \"{wall}\": the wall never turns (give it a rotation, or a phase's move)")));
                }
                if !(window[0] >= 0.0 && window[1] > window[0]) {
                    return Err(TalusError::Input(format!("{path}: analysis.window = {window:?}: must be [from, to] times (s), 0 <= from < to")));
                }
                if !case.output.final_state {
                    return Err(TalusError::Input(format!("{path}: analysis.kind = \"drum\": needs output.final_state = true (the angle of repose is measured from final.csv)")));
                }
                Analysis::None
            }
            Some(AnalysisSection::Collision { particle, wall, partner }) => {
                let i = particle_index(*particle, "particle")?;
                let (n, wall, partner) = match (wall, partner) {
                    (Some(w), None) => {
                        let wi = wall_index(w, "wall")?;
                        let Shape::Plane(pl) = &walls[wi].shape else {
                            return Err(TalusError::Input(format!(
                                "{path}: analysis.wall = \"{w}\": a collision analysis needs a plane wall"
                            )));
                        };
                        (pl.normal, Some(wi), None)
                    }
                    (None, Some(j)) if j == particle => {
                        return Err(TalusError::Input(format!(
                            "{path}: analysis.partner = {j}: the partner is the particle itself (analysis.particle = {particle}); name another particle, or a wall"
                        )));
                    }
                    (None, Some(j)) => {
                        let j = particle_index(*j, "partner")?;
                        ((p.pos[i] - p.pos[j]).normalize(), None, Some(j))
                    }
                    _ => {
                        return Err(TalusError::Input(format!(
                            "{path}: analysis: a collision names exactly one of wall and partner"
                        )));
                    }
                };
                let v_in = relative_velocity(p, i, partner);
                let t = tangential_frame(p, i, partner, n);
                Analysis::Collision(Collision {
                    particle: *particle,
                    partner: partner.map(|j| p.id[j]),
                    wall,
                    n,
                    t,
                    v_in,
                    prev: None,
                    start: None,
                    end: None,
                    max_overlap: 0.0,
                    max_force: 0.0,
                })
            }
            Some(AnalysisSection::Hopper { hopper_walls, gate, fill_phase, discharge_phase, fill_window }) => {
                let ws = hopper_walls.iter().map(|w| wall_index(w, "hopper_walls")).collect::<Result<Vec<_>, _>>()?;
                for ph in [fill_phase, discharge_phase] {
                    if !case.phases.iter().any(|x| &x.name == ph) {
                        return Err(TalusError::Input(format!("{path}: analysis: no phase named \"{ph}\"")));
                    }
                }
                let total_mass = p.total_mass();
                let g = case.simulation.gravity;
                Analysis::Hopper(Hopper {
                    walls: ws,
                    gate: wall_index(gate, "gate")?,
                    fill: fill_phase.clone(),
                    window: *fill_window,
                    recent: VecDeque::new(),
                    fill_end: None,
                    discharge_start: None,
                    discharged: Vec::new(),
                    total_mass,
                    total_weight: total_mass * (g[0] * g[0] + g[1] * g[1] + g[2] * g[2]).sqrt(),
                })
            }
        })
    }

    /// Global ids of the particles `record` and `figures` need, in order.
    pub fn ids(&self) -> Vec<u64> {
        match self {
            Analysis::Collision(c) => std::iter::once(c.particle).chain(c.partner).collect(),
            _ => Vec::new(),
        }
    }

    /// Record after a step (and once before the first); `tracked` holds the
    /// records of `ids()`, gathered from whichever ranks own them.
    pub fn record(&mut self, st: &State, tracked: &[Option<Record>]) {
        match self {
            Analysis::None => {}
            Analysis::Collision(c) => {
                let (a, b) = pair_of(tracked);
                // `Analysis::new` takes a partner particle or an active plane
                // wall; anything else (a removed wall) is out of contact
                let overlap = match (b, c.wall.map(|w| &st.walls[w])) {
                    (Some(b), _) => a.radius + b.radius - (a.pos - b.pos).norm(),
                    (_, Some(w)) => match &w.shape {
                        Shape::Plane(pl) if w.active => a.radius - pl.distance(&a.pos),
                        _ => -a.radius,
                    },
                    (None, None) => -a.radius,
                };
                let t = st.time;
                if let Some((t0, o0)) = c.prev {
                    if o0 <= 0.0 && overlap > 0.0 && c.start.is_none() {
                        c.start = Some(t0 + (t - t0) * (-o0) / (overlap - o0));
                    }
                    if o0 > 0.0 && overlap <= 0.0 && c.start.is_some() && c.end.is_none() {
                        c.end = Some(t0 + (t - t0) * o0 / (o0 - overlap));
                    }
                }
                if overlap > 0.0 {
                    c.max_overlap = c.max_overlap.max(overlap);
                    c.max_force = c.max_force.max(a.force.dot(&c.n).abs());
                }
                c.prev = Some((t, overlap));
            }
            Analysis::Hopper(h) => {
                let down = |w: usize| -st.walls[w].force.z;
                let walls: f64 = h.walls.iter().map(|&w| down(w)).sum();
                let gate = if st.walls[h.gate].active { down(h.gate) } else { 0.0 };
                h.recent.push_back((st.time, walls, gate));
                while let Some(&(t0, _, _)) = h.recent.front() {
                    if t0 < st.time - h.window - 1e-12 {
                        h.recent.pop_front();
                    } else {
                        break;
                    }
                }
            }
        }
    }

    /// Sample the discharged mass (called at each output interval).
    pub fn sample(&mut self, time: f64, mass_below: f64) {
        if let Analysis::Hopper(h) = self {
            if let Some(t0) = h.discharge_start {
                h.discharged.push((time - t0, mass_below));
            }
        }
    }

    pub fn phase_end(&mut self, name: &str, time: f64) {
        if let Analysis::Hopper(h) = self {
            if name == h.fill {
                let n = h.recent.len().max(1) as f64;
                let w = h.recent.iter().map(|x| x.1).sum::<f64>() / n;
                let g = h.recent.iter().map(|x| x.2).sum::<f64>() / n;
                h.fill_end = Some((time, w, g));
                h.discharge_start = Some(time);
                h.discharged.push((0.0, 0.0));
            }
        }
    }

    /// The figures for `summary.json`.
    pub fn figures(&self, tracked: &[Option<Record>]) -> Map<String, Value> {
        let mut m = Map::new();
        match self {
            Analysis::None => {}
            Analysis::Collision(c) => {
                let (a, b) = pair_of(tracked);
                let v_out = a.vel - b.map(|b| b.vel).unwrap_or_else(Vec3::zeros);
                let vn_in = c.v_in.dot(&c.n);
                let vn_out = v_out.dot(&c.n);
                m.insert("restitution".into(), json!(-vn_out / vn_in));
                let dur = match (c.start, c.end) {
                    (Some(a), Some(b)) => json!(b - a),
                    _ => Value::Null,
                };
                m.insert("contact_duration_s".into(), dur);
                m.insert("max_overlap_m".into(), json!(c.max_overlap));
                m.insert("max_normal_force_n".into(), json!(c.max_force));
                let vt_in = c.v_in.dot(&c.t);
                let vt_out = v_out.dot(&c.t);
                m.insert("tangential_rebound_m_s".into(), json!(vt_out));
                m.insert(
                    "tangential_restitution".into(),
                    if vt_in != 0.0 { json!(vt_out / vt_in) } else { Value::Null },
                );
                let axis = c.n.cross(&c.t);
                m.insert("spin_rad_s".into(), json!(a.omega.dot(&axis)));
                let impact_angle = c.v_in.dot(&c.t).atan2(-vn_in).to_degrees();
                m.insert("impact_angle_deg".into(), json!(impact_angle));
            }
            Analysis::Hopper(h) => {
                if let Some((t, w, g)) = h.fill_end {
                    m.insert("fill_end_time_s".into(), json!(t));
                    m.insert("fill_end_wall_force_z_n".into(), json!(w));
                    m.insert("fill_end_gate_force_z_n".into(), json!(g));
                    m.insert("fill_end_force_balance".into(), json!((w + g) / h.total_weight));
                }
                m.insert("total_weight_n".into(), json!(h.total_weight));
                m.insert("total_mass_kg".into(), json!(h.total_mass));
                let (rate, complete) = discharge_rate(&h.discharged, h.total_mass);
                m.insert("discharge_rate_kg_s".into(), rate.map(|r| json!(r)).unwrap_or(Value::Null));
                m.insert("discharge_reached_80_percent".into(), json!(complete));
                if let Some(&(_, last)) = h.discharged.last() {
                    m.insert("discharged_mass_kg".into(), json!(last));
                }
            }
        }
        m
    }
}

/// Least-squares slope of discharged mass against time between 20% and 80% of
/// the total mass. Returns the slope and whether 80% was reached (if not, the
/// fit runs from 20% to the end).
pub fn discharge_rate(series: &[(f64, f64)], total: f64) -> (Option<f64>, bool) {
    let lo = 0.2 * total;
    let hi = 0.8 * total;
    let pts: Vec<(f64, f64)> = series.iter().copied().filter(|&(_, m)| m >= lo && m <= hi).collect();
    let complete = series.iter().any(|&(_, m)| m > hi);
    if pts.len() < 3 {
        return (None, complete);
    }
    let n = pts.len() as f64;
    let (st, sm) = pts.iter().fold((0.0, 0.0), |a, &(t, m)| (a.0 + t, a.1 + m));
    let (mt, mm) = (st / n, sm / n);
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for &(t, m) in &pts {
        sxy += (t - mt) * (m - mm);
        sxx += (t - mt) * (t - mt);
    }
    (Some(sxy / sxx), complete)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn discharge_fit_recovers_a_linear_rate() {
        let s: Vec<(f64, f64)> = (0..200).map(|k| (k as f64 * 0.01, (0.4 * (k as f64 * 0.01 - 0.2)).clamp(0.0, 0.5))).collect();
        let (r, done) = discharge_rate(&s, 0.5);
        assert!(done);
        assert!((r.unwrap() - 0.4).abs() < 1e-9);
    }
}
