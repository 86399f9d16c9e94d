//! Set-up generators: the seeded jittered-lattice cloud of CASES.md, the CSV
//! particle reader, and the H1 hopper meshes.

use crate::case::LatticeSection;
use crate::dim::Vec3;
use crate::error::TalusError;
use crate::particles::ParticleInit;
use crate::walls::mesh::{push_quad, Mesh};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// A loose cloud on a jittered lattice: nodes `spacing * radius_max` apart from
/// `lo` upward, radii uniform in [radius_min, radius_max], each centre jittered
/// inside its lattice cell so that no two spheres overlap. ChaCha8 seeded from
/// `seed`: the same cloud on every machine. Ids run 1..=count in lattice order.
pub fn lattice_cloud(l: &LatticeSection) -> Vec<ParticleInit> {
    let mut rng = ChaCha8Rng::seed_from_u64(l.seed);
    let s = l.spacing * l.radius_max;
    let nx = (((l.hi_xy[0] - l.lo[0]) / s).floor() as usize).max(1);
    let ny = (((l.hi_xy[1] - l.lo[1]) / s).floor() as usize).max(1);
    let layer = nx.saturating_mul(ny);
    let mut out = Vec::with_capacity(l.count);
    let mut k = 0usize;
    while out.len() < l.count {
        let (iz, rem) = (k / layer, k % layer);
        let (iy, ix) = (rem / nx, rem % nx);
        k += 1;
        let r = l.radius_min + (l.radius_max - l.radius_min) * rng.random::<f64>();
        let room = 0.5 * s - r;
        let mut jit = || room * (2.0 * rng.random::<f64>() - 1.0);
        let c = Vec3::new(
            l.lo[0] + (ix as f64 + 0.5) * s + jit(),
            l.lo[1] + (iy as f64 + 0.5) * s + jit(),
            l.lo[2] + (iz as f64 + 0.5) * s + jit(),
        );
        out.push(ParticleInit { id: out.len() as u64 + 1, pos: c, vel: Vec3::zeros(), omega: Vec3::zeros(), radius: r });
    }
    out
}

/// Read particles from CSV: header `id,x,y,z,radius` and optionally
/// `vx,vy,vz` and `wx,wy,wz`. Errors name the file, the line and the value.
pub fn read_csv(path: &Path) -> Result<Vec<ParticleInit>, TalusError> {
    let name = path.display().to_string();
    let mut rdr = csv::ReaderBuilder::new()
        .trim(csv::Trim::All)
        .comment(Some(b'#'))
        .from_path(path)
        .map_err(|e| TalusError::Input(format!("{name}: cannot read particle CSV: {e}")))?;
    let headers = rdr.headers().map_err(|e| TalusError::Input(format!("{name}: bad CSV header: {e}")))?.clone();
    let col = |h: &str| headers.iter().position(|x| x == h);
    let need = ["id", "x", "y", "z", "radius"];
    let mut idx = [0usize; 5];
    for (k, h) in need.iter().enumerate() {
        idx[k] = col(h).ok_or_else(|| {
            TalusError::Input(format!("{name}, line 1: the header must name columns id,x,y,z,radius; `{h}` is missing"))
        })?;
    }
    let known = ["id", "x", "y", "z", "radius", "vx", "vy", "vz", "wx", "wy", "wz"];
    if let Some(h) = headers.iter().find(|h| !known.contains(h)) {
        return Err(TalusError::Input(format!("{name}, line 1: unknown column `{h}` (known: {})", known.join(","))));
    }
    if let Some((k, h)) = headers.iter().enumerate().find(|(k, h)| headers.iter().take(*k).any(|x| x == *h)) {
        return Err(TalusError::Input(format!("{name}, line 1: column `{h}` appears twice (column {})", k + 1)));
    }
    // velocity and spin: all three components or none
    let opt = |cols: [&str; 3]| -> Result<Option<[usize; 3]>, TalusError> {
        match cols.map(col) {
            [Some(x), Some(y), Some(z)] => Ok(Some([x, y, z])),
            [None, None, None] => Ok(None),
            found => {
                let pick = |want: bool| -> Vec<&str> {
                    cols.iter().zip(found).filter(|(_, f)| f.is_some() == want).map(|(c, _)| *c).collect()
                };
                Err(TalusError::Input(format!(
                    "{name}, line 1: the header has `{}` but not `{}`: give all of {} or none",
                    pick(true).join("`, `"),
                    pick(false).join("`, `"),
                    cols.join(",")
                )))
            }
        }
    };
    let vcols = opt(["vx", "vy", "vz"])?;
    let wcols = opt(["wx", "wy", "wz"])?;
    let mut out = Vec::new();
    let mut seen = std::collections::HashSet::new();
    for rec in rdr.records() {
        let rec = rec.map_err(|e| TalusError::Input(format!("{name}: {e}")))?;
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        let num = |c: usize, h: &str| -> Result<f64, TalusError> {
            let s = rec.get(c).unwrap_or("");
            s.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                TalusError::Input(format!("{name}, line {line}: column {h} = `{s}` is not a finite number"))
            })
        };
        let ids = rec.get(idx[0]).unwrap_or("");
        let id: u64 = ids
            .parse()
            .map_err(|_| TalusError::Input(format!("{name}, line {line}: id = `{ids}` is not a non-negative integer")))?;
        if !seen.insert(id) {
            return Err(TalusError::Input(format!("{name}, line {line}: id = {id} appears twice")));
        }
        let radius = num(idx[4], "radius")?;
        if radius <= 0.0 {
            return Err(TalusError::Input(format!("{name}, line {line}: radius = {radius}: a radius must be positive")));
        }
        let pos = Vec3::new(num(idx[1], "x")?, num(idx[2], "y")?, num(idx[3], "z")?);
        let v3 = |c: Option<[usize; 3]>, h: [&str; 3]| -> Result<Vec3, TalusError> {
            match c {
                Some(c) => Ok(Vec3::new(num(c[0], h[0])?, num(c[1], h[1])?, num(c[2], h[2])?)),
                None => Ok(Vec3::zeros()),
            }
        };
        let vel = v3(vcols, ["vx", "vy", "vz"])?;
        let omega = v3(wcols, ["wx", "wy", "wz"])?;
        out.push(ParticleInit { id, pos, vel, omega, radius });
    }
    if out.is_empty() {
        return Err(TalusError::Input(format!("{name}: no particles in the file")));
    }
    Ok(out)
}

/// Write particles as CSV (`id,x,y,z,radius,vx,vy,vz`), full precision.
pub fn write_csv(path: &Path, ps: &[ParticleInit]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(f, "id,x,y,z,radius,vx,vy,vz")?;
    for p in ps {
        writeln!(
            f,
            "{},{:e},{:e},{:e},{:e},{:e},{:e},{:e}",
            p.id, p.pos.x, p.pos.y, p.pos.z, p.radius, p.vel.x, p.vel.y, p.vel.z
        )?;
    }
    Ok(())
}

/// The H1 hopper of CASES.md: (bin plus converging section, lower box), as meshes.
pub fn hopper_meshes() -> (Mesh, Mesh) {
    let (h_bin, z_bin_lo, z_bin_hi, h_out) = (0.05, 0.05, 0.30, 0.02);
    let mut v = Vec::new();
    let mut t = Vec::new();
    let corners = |h: f64, z: f64| -> [Vec3; 4] {
        [Vec3::new(-h, -h, z), Vec3::new(h, -h, z), Vec3::new(h, h, z), Vec3::new(-h, h, z)]
    };
    let top = corners(h_bin, z_bin_hi);
    let mid = corners(h_bin, z_bin_lo);
    let bot = corners(h_out, 0.0);
    for k in 0..4 {
        let k2 = (k + 1) % 4;
        push_quad(&mut v, &mut t, [mid[k], mid[k2], top[k2], top[k]]);
        push_quad(&mut v, &mut t, [bot[k], bot[k2], mid[k2], mid[k]]);
    }
    let hopper = Mesh::new(v, t).expect("hopper mesh");
    let (hb, zf) = (0.10, -0.10);
    let mut v = Vec::new();
    let mut t = Vec::new();
    let floor = corners(hb, zf);
    let rim = corners(hb, 0.0);
    push_quad(&mut v, &mut t, floor);
    for k in 0..4 {
        let k2 = (k + 1) % 4;
        push_quad(&mut v, &mut t, [floor[k], floor[k2], rim[k2], rim[k]]);
    }
    let lower = Mesh::new(v, t).expect("box mesh");
    (hopper, lower)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lat(count: usize) -> LatticeSection {
        LatticeSection {
            count,
            radius_min: 1.95e-3,
            radius_max: 2.35e-3,
            lo: [-0.046, -0.046, 0.06],
            hi_xy: [0.046, 0.046],
            spacing: 2.2,
            seed: 7,
        }
    }

    #[test]
    fn cloud_is_seeded_and_overlap_free() {
        let a = lattice_cloud(&lat(2000));
        let b = lattice_cloud(&lat(2000));
        assert_eq!(a, b);
        assert_eq!(a.len(), 2000);
        for i in 0..a.len() {
            assert!(a[i].radius >= 1.95e-3 && a[i].radius <= 2.35e-3);
            assert!(a[i].pos.x - a[i].radius >= -0.046 && a[i].pos.x + a[i].radius <= 0.046);
            for j in i + 1..a.len().min(i + 400) {
                assert!((a[i].pos - a[j].pos).norm() > a[i].radius + a[j].radius);
            }
        }
    }

    #[test]
    fn hopper_meshes_are_closed_where_they_should_be() {
        let (h, b) = hopper_meshes();
        assert_eq!(h.triangles.len(), 16);
        assert_eq!(b.triangles.len(), 10);
        // a sphere of radius 30 mm at the axis, 10 mm above the orifice, touches each of the
        // four converging faces once (each face is two triangles sharing a diagonal)
        let c = Vec3::new(0.0, 0.0, 0.01);
        let hits: Vec<_> = (0..h.triangles.len()).filter_map(|t| h.contact(t, &c, 0.03)).collect();
        assert_eq!(hits.len(), 4, "{hits:?}");
    }
}
