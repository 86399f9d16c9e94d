//! `talus export CASE --to liggghts|yade|lammps --out DIR`: a case written as a
//! self-contained input for a reference code, in that code's conventions,
//! writing the same probes as talus's `probes.csv` (same columns, units and
//! interval). What the code cannot run is refused with the key and the reason.
//!
//! The exporter works from the case as talus builds it (`Simulation::new`):
//! the initial particles (a lattice cloud included), the resolved time step
//! and skin, the meshes as loaded. So an exported deck runs the very particles
//! talus starts from.

pub mod lammps;
pub mod liggghts;
pub mod yade;

use crate::case::{Case, OscillationSection, RotationSection};
use crate::error::TalusError;
use std::path::{Path, PathBuf};

/// A reference code an exported case runs in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Liggghts,
    Yade,
    Lammps,
}

impl Target {
    pub fn parse(s: &str) -> Result<Target, TalusError> {
        match s {
            "liggghts" => Ok(Target::Liggghts),
            "yade" => Ok(Target::Yade),
            "lammps" => Ok(Target::Lammps),
            _ => Err(TalusError::Input(format!("--to {s}: must be liggghts, yade or lammps"))),
        }
    }
}

/// What an export wrote.
pub struct Exported {
    /// The input to run (the deck), then every other file written.
    pub files: Vec<PathBuf>,
    /// How to run it.
    pub command: String,
    /// Where the exported set-up differs from the case, by the target's conventions.
    pub notes: Vec<String>,
}

/// Export `case` for `target` into `out` (created).
pub fn export(case: &Case, target: Target, out: &Path) -> Result<Exported, TalusError> {
    export_with(case, target, out, None)
}

/// Export `case`, a case that inserts particles with `inserted`, the
/// `inserted.csv` of a talus run of it (where the inserted particles go
/// depends on the run: the reference gets the very particles talus inserted,
/// at the same steps).
pub fn export_with(case: &Case, target: Target, out: &Path, inserted: Option<&Path>) -> Result<Exported, TalusError> {
    let rows = inserted_rows(case, inserted)?;
    std::fs::create_dir_all(out).map_err(|e| TalusError::io(format!("cannot create {}", out.display()), e))?;
    match target {
        Target::Liggghts => liggghts::export(case, out, &rows),
        Target::Yade => yade::export(case, out, &rows),
        Target::Lammps if rows.is_empty() => lammps::export(case, out),
        Target::Lammps => Err(refuse(case, "--inserted", "the LAMMPS export inserts no particles")),
    }
}

/// One particle a talus run inserted (a row of its `inserted.csv`).
#[derive(Clone, Debug, PartialEq)]
pub struct InsertedRow {
    /// It came in at the start of this step (after this many steps).
    pub step: u64,
    pub id: u64,
    pub pos: [f64; 3],
    pub vel: [f64; 3],
    pub radius: f64,
    pub material: u16,
}

/// The particles a run of `case` inserted, from its `inserted.csv`; none for a
/// case without insertions. A case with insertions needs the file.
pub fn inserted_rows(case: &Case, path: Option<&Path>) -> Result<Vec<InsertedRow>, TalusError> {
    let Some(ph) = case.phases.iter().find(|p| !p.inserts.is_empty()) else { return Ok(Vec::new()) };
    let Some(path) = path else {
        return Err(refuse(
            case,
            &format!("phase.{}.insert", ph.name),
            "where inserted particles go depends on the run: export with --inserted OUT/inserted.csv from `talus run` of this case (python -m compare does)",
        ));
    };
    let text = std::fs::read_to_string(path).map_err(|e| TalusError::io(format!("cannot read {}", path.display()), e))?;
    let mut rows = Vec::new();
    for (n, line) in text.lines().enumerate().skip(1) {
        let bad = |why: &str| TalusError::Input(format!("{}: line {}: {why}: {line}", path.display(), n + 1));
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 11 {
            return Err(bad("expected 11 columns (step,time_s,id,x_m,y_m,z_m,vx_m_s,vy_m_s,vz_m_s,radius_m,material)"));
        }
        let num = |k: usize| f[k].trim().parse::<f64>().map_err(|_| bad(&format!("column {} is not a number", k + 1)));
        let int = |k: usize| f[k].trim().parse::<u64>().map_err(|_| bad(&format!("column {} is not a whole number", k + 1)));
        let material = int(10)?;
        if material as usize >= case.materials.len() {
            return Err(bad("no material of that index in the case"));
        }
        rows.push(InsertedRow {
            step: int(0)?,
            id: int(2)?,
            pos: [num(3)?, num(4)?, num(5)?],
            vel: [num(6)?, num(7)?, num(8)?],
            radius: num(9)?,
            material: material as u16,
        });
    }
    Ok(rows)
}

/// A wall's motion from the start of a phase on, as the case gives it.
#[derive(Clone, Debug)]
pub struct MotionAt<'a> {
    /// The phase it starts with (0: from the start of the run).
    pub phase: usize,
    /// The key that gives it (`wall.NAME` or `phase.NAME.move[k]`).
    pub key: String,
    pub velocity: [f64; 3],
    pub rotation: Option<&'a RotationSection>,
    pub oscillation: Option<&'a OscillationSection>,
}

impl MotionAt<'_> {
    pub fn is_still(&self) -> bool {
        self.velocity == [0.0; 3] && self.oscillation.is_none() && self.rotation.is_none_or(|r| r.angular_velocity == 0.0)
    }
}

/// Wall `name`'s motions in phase order: its own from the start (or phase 0's
/// move instead), then each later phase's move.
pub fn wall_motions<'a>(case: &'a Case, name: &str) -> Vec<MotionAt<'a>> {
    let w = case.walls.iter().find(|w| w.name == name).expect("a wall of the case");
    let mut out = vec![MotionAt {
        phase: 0,
        key: format!("wall.{name}"),
        velocity: w.velocity,
        rotation: w.rotation.as_ref(),
        oscillation: w.oscillation.as_ref(),
    }];
    for (i, ph) in case.phases.iter().enumerate() {
        for (k, m) in ph.moves.iter().enumerate().filter(|(_, m)| m.wall == name) {
            let at = MotionAt {
                phase: i,
                key: format!("phase.{}.move[{k}]", ph.name),
                velocity: m.velocity,
                rotation: m.rotation.as_ref(),
                oscillation: m.oscillation.as_ref(),
            };
            if i == 0 {
                out[0] = at;
            } else {
                out.push(at);
            }
        }
    }
    out
}

/// A refusal: the case's key and why the target cannot run it.
pub(crate) fn refuse(case: &Case, key: &str, why: &str) -> TalusError {
    TalusError::Input(format!("{}: {key}: {why}", case.path.display()))
}

/// Steps a phase of `duration` (s) runs from step `s0`, exactly as
/// `Simulation::advance_phase` decides (elapsed >= duration - dt/2).
pub fn phase_steps(s0: u64, duration: f64, dt: f64) -> u64 {
    let start = s0 as f64 * dt;
    // first guess, then the exact test in the engine's arithmetic
    let mut n = ((duration / dt) - 0.5).ceil().max(0.0) as u64;
    while n > 0 && ((s0 + n - 1) as f64 * dt - start) >= duration - 0.5 * dt {
        n -= 1;
    }
    while ((s0 + n) as f64 * dt - start) < duration - 0.5 * dt {
        n += 1;
    }
    n
}

/// The step at the end of which a wall with `remove_at` (s) is removed
/// (`Simulation::step`: t >= remove_at - dt/2 after the step).
pub fn removal_step(remove_at: f64, dt: f64) -> u64 {
    let mut s = ((remove_at / dt) - 0.5).ceil().max(1.0) as u64;
    while s > 1 && (s - 1) as f64 * dt >= remove_at - 0.5 * dt {
        s -= 1;
    }
    while (s as f64 * dt) < remove_at - 0.5 * dt {
        s += 1;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_steps_match_the_engine_rule() {
        let dt = 1.0673161788874508e-4;
        for s0 in [0u64, 1, 17, 6475] {
            for d in [0.004, 0.2, 1.5, 0.01] {
                let n = phase_steps(s0, d, dt);
                let t = |k: u64| k as f64 * dt - s0 as f64 * dt;
                assert!(t(s0 + n) >= d - 0.5 * dt && (n == 0 || t(s0 + n - 1) < d - 0.5 * dt));
            }
        }
        assert_eq!(phase_steps(0, 0.004, 5e-6), 800);
    }

    #[test]
    fn removal_step_is_the_first_step_past_the_time() {
        let dt = 1e-4;
        let s = removal_step(0.05, dt);
        assert_eq!(s, 500);
        assert!(s as f64 * dt >= 0.05 - 0.5 * dt && ((s - 1) as f64 * dt) < 0.05 - 0.5 * dt);
    }
}

/// The probe columns a LAMMPS-family deck (LIGGGHTS, LAMMPS) writes alike:
/// the mass below `output.mass_below_z` and the momentum, as variables with
/// their `probes.csv` header, `fix print` row and thermo terms (the computes
/// in the thermo output, so they are current at the end of every run).
pub(crate) fn lammps_family_columns(case: &Case, w: &mut String, header: &mut String, row: &mut String, thermo: &mut String) {
    use std::fmt::Write as _;
    if let Some(z) = case.output.mass_below_z {
        let _ = writeln!(w, "variable mb_atom atom mass*(z<{z:.16e})\ncompute mb_sum grains reduce sum v_mb_atom\nvariable mb equal c_mb_sum");
        header.push_str(",mass_below_kg");
        row.push_str(",${mb}");
        thermo.push_str(" v_mb");
    }
    if case.output.momentum {
        for c in ["x", "y", "z"] {
            let _ = writeln!(w, "variable p{c}_atom atom mass*v{c}");
        }
        let _ = writeln!(w, "compute mom grains reduce sum v_px_atom v_py_atom v_pz_atom");
        for (k, c) in ["x", "y", "z"].iter().enumerate() {
            let _ = writeln!(w, "variable mom_{c} equal c_mom[{}]", k + 1);
            let _ = write!(header, ",momentum_{c}_kg_m_s");
            let _ = write!(row, ",${{mom_{c}}}");
            let _ = write!(thermo, " v_mom_{c}");
        }
    }
}

/// Steps between probe rows in a deck: the case's interval rounded to whole
/// steps, with a note where that is not the interval itself.
pub(crate) fn probe_every(case: &Case, dt: f64, notes: &mut Vec<String>) -> u64 {
    steps_every("probes", "a row", case.output.interval, dt, notes)
}

/// Steps between outputs (`what`, each `one`) written every `interval` (s)
/// in a deck: the interval rounded to whole steps, with a note where that is
/// not the interval itself.
pub(crate) fn steps_every(what: &str, one: &str, interval: f64, dt: f64, notes: &mut Vec<String>) -> u64 {
    let every = ((interval / dt).round() as u64).max(1);
    if (every as f64 * dt - interval).abs() > 1e-9 * interval {
        notes.push(format!(
            "{what} every {every} steps ({:.9e} s; talus writes {one} at each step that crosses a multiple of {interval} s)",
            every as f64 * dt
        ));
    }
    every
}
