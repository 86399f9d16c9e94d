//! Triangle-mesh walls read from STL (ASCII or binary, through `stl_io`).
//!
//! At load time the mesh builds its adjacency and gives every edge and every
//! vertex one owner (the lowest-indexed triangle that has it), as LIGGGHTS does.
//! A sphere whose closest point on a triangle is an edge or a vertex gets that
//! contact only from the owner, and only if the feature really is the closest
//! point of the whole mesh around it: every other triangle sharing the edge must
//! find its own closest point on that edge (not in its face), and every other
//! triangle at the vertex must find its closest point at that vertex. The test
//! reuses the very classification the neighbours make for themselves, so there
//! is no band near an edge where both a face and an edge contact are kept. A
//! sphere on a shared edge of two coplanar triangles gets one contact, a sphere
//! on a face near a convex edge gets only the face contact, and a sphere in a
//! concave corner gets one contact from each face. Meshes are two-sided.

use crate::dim::Vec3;
use crate::error::TalusError;
use crate::walls::WallHit;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::Path;

/// Where on a triangle the closest point to a query lies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    Face,
    /// Edge k runs from vertex k to vertex (k + 1) % 3.
    Edge(usize),
    Vertex(usize),
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Unit face normals (orientation as in the file, but contact is two-sided).
    pub normals: Vec<Vec3>,
    /// Per triangle and edge: does this triangle own the edge?
    edge_owned: Vec<[bool; 3]>,
    /// Per triangle and vertex: does this triangle own the vertex?
    vertex_owned: Vec<[bool; 3]>,
    /// Per triangle and edge: range in `edge_tris` of the other triangles sharing the edge.
    edge_nb: Vec<[(u32, u32); 3]>,
    edge_tris: Vec<u32>,
    /// Per vertex: range in `vertex_tris` of the triangles that have it.
    vertex_nb: Vec<(u32, u32)>,
    vertex_tris: Vec<u32>,
    /// Per triangle bounding box (lo, hi).
    aabb: Vec<(Vec3, Vec3)>,
    /// Bounding box of the whole mesh.
    bounds: (Vec3, Vec3),
}

/// Closest point on triangle (a, b, c) to p, with its region (Ericson,
/// Real-Time Collision Detection, 5.1.5). The face region is the open interior.
#[inline(always)]
pub fn closest_point(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> (Vec3, Region) {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(&ap);
    let d2 = ac.dot(&ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, Region::Vertex(0));
    }
    let bp = p - b;
    let d3 = ab.dot(&bp);
    let d4 = ac.dot(&bp);
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, Region::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, Region::Edge(0));
    }
    let cp = p - c;
    let d5 = ab.dot(&cp);
    let d6 = ac.dot(&cp);
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, Region::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, Region::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, Region::Edge(1));
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    (a + ab * v + ac * w, Region::Face)
}

impl Mesh {
    /// Read an STL file (ASCII or binary). Errors name the file and the line
    /// (ASCII), the facet count and size (binary), or the facet.
    pub fn from_stl(path: &Path) -> Result<Mesh, TalusError> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| TalusError::io(format!("cannot open STL file {name}"), e))?;
        check_stl(&name, &bytes)?;
        let im = stl_io::read_stl(&mut std::io::Cursor::new(&bytes))
            .map_err(|e| TalusError::Input(format!("{name}: not a readable STL file (ASCII or binary): {e}")))?;
        if im.faces.is_empty() {
            return Err(TalusError::Input(format!("{name}: the STL file has no facets")));
        }
        if let Some(k) = im.faces.iter().position(|f| f.vertices.iter().any(|&v| im.vertices[v].0.iter().any(|x| !x.is_finite()))) {
            return Err(TalusError::Input(format!("{name}: facet {k} has a vertex that is not a finite number")));
        }
        let vertices: Vec<Vec3> =
            im.vertices.iter().map(|v| Vec3::new(v[0] as f64, v[1] as f64, v[2] as f64)).collect();
        let triangles: Vec<[u32; 3]> =
            im.faces.iter().map(|f| [f.vertices[0] as u32, f.vertices[1] as u32, f.vertices[2] as u32]).collect();
        Mesh::new(vertices, triangles).map_err(|e| TalusError::Input(format!("{name}: {e}")))
    }

    /// Build a mesh from vertices and triangles; checks for non-finite vertices and degenerate facets.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh, String> {
        for (i, v) in vertices.iter().enumerate() {
            if !(v.x.is_finite() && v.y.is_finite() && v.z.is_finite()) {
                return Err(format!("vertex {i} is not finite: {v:?}"));
            }
        }
        let mut lo = Vec3::repeat(f64::INFINITY);
        let mut hi = Vec3::repeat(f64::NEG_INFINITY);
        for v in &vertices {
            lo = lo.inf(v);
            hi = hi.sup(v);
        }
        let scale = (hi - lo).norm().max(f64::MIN_POSITIVE);
        let mut normals = Vec::with_capacity(triangles.len());
        for (t, tri) in triangles.iter().enumerate() {
            let [a, b, c] = tri.map(|k| vertices[k as usize]);
            let nrm = (b - a).cross(&(c - a));
            let area2 = nrm.norm();
            if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || area2 <= 1e-12 * scale * scale {
                return Err(format!(
                    "facet {t} is degenerate (zero area): vertices ({:.6e}, {:.6e}, {:.6e}), ({:.6e}, {:.6e}, {:.6e}), ({:.6e}, {:.6e}, {:.6e})",
                    a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z
                ));
            }
            normals.push(nrm / area2);
        }
        // edges: sorted vertex pair -> triangles (in index order)
        let mut edges: HashMap<(u32, u32), Vec<(u32, usize)>> = HashMap::new();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                edges.entry((a.min(b), a.max(b))).or_default().push((t as u32, k));
            }
        }
        let nt = triangles.len();
        let mut edge_owned = vec![[false; 3]; nt];
        let mut edge_nb = vec![[(0u32, 0u32); 3]; nt];
        let mut edge_tris = Vec::new();
        for (t, tri) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                let sharers = &edges[&(a.min(b), a.max(b))];
                edge_owned[t][k] = sharers[0].0 as usize == t;
                let start = edge_tris.len() as u32;
                edge_tris.extend(sharers.iter().map(|x| x.0).filter(|&u| u as usize != t));
                edge_nb[t][k] = (start, edge_tris.len() as u32);
            }
        }
        // vertices: owner and incident triangles (in index order)
        let nv = vertices.len();
        let mut first = vec![u32::MAX; nv];
        let mut incident: Vec<Vec<u32>> = vec![Vec::new(); nv];
        for (t, tri) in triangles.iter().enumerate() {
            for &v in tri {
                if first[v as usize] == u32::MAX {
                    first[v as usize] = t as u32;
                }
                incident[v as usize].push(t as u32);
            }
        }
        let mut vertex_nb = Vec::with_capacity(nv);
        let mut vertex_tris = Vec::new();
        for inc in &incident {
            let s = vertex_tris.len() as u32;
            vertex_tris.extend_from_slice(inc);
            vertex_nb.push((s, vertex_tris.len() as u32));
        }
        let vertex_owned =
            triangles.iter().enumerate().map(|(t, tri)| tri.map(|v| first[v as usize] as usize == t)).collect();
        let mut m = Mesh {
            vertices,
            triangles,
            normals,
            edge_owned,
            vertex_owned,
            edge_nb,
            edge_tris,
            vertex_nb,
            vertex_tris,
            aabb: Vec::new(),
            bounds: (Vec3::zeros(), Vec3::zeros()),
        };
        m.update_boxes();
        Ok(m)
    }

    fn update_boxes(&mut self) {
        self.aabb = (0..self.triangles.len())
            .map(|t| {
                let [a, b, c] = self.corners(t);
                (a.inf(&b).inf(&c), a.sup(&b).sup(&c))
            })
            .collect();
        let lo = self.aabb.iter().fold(Vec3::repeat(f64::INFINITY), |m, b| m.inf(&b.0));
        let hi = self.aabb.iter().fold(Vec3::repeat(f64::NEG_INFINITY), |m, b| m.sup(&b.1));
        self.bounds = (lo, hi);
    }

    pub fn translate(&mut self, d: Vec3) {
        for v in &mut self.vertices {
            *v += d;
        }
        for b in &mut self.aabb {
            b.0 += d;
            b.1 += d;
        }
        self.bounds.0 += d;
        self.bounds.1 += d;
    }

    #[inline(always)]
    fn outside(lo: &Vec3, hi: &Vec3, c: &Vec3, reach: f64) -> bool {
        c.x < lo.x - reach || c.x > hi.x + reach || c.y < lo.y - reach || c.y > hi.y + reach || c.z < lo.z - reach || c.z > hi.z + reach
    }

    #[inline(always)]
    fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|k| self.vertices[k as usize])
    }

    /// Triangles whose distance from c is below `reach`.
    pub fn candidates(&self, c: &Vec3, reach: f64, out: &mut Vec<u32>) {
        if Self::outside(&self.bounds.0, &self.bounds.1, c, reach) {
            return;
        }
        for (t, (lo, hi)) in self.aabb.iter().enumerate() {
            if Self::outside(lo, hi, c, reach) {
                continue;
            }
            let [a, b, d] = self.corners(t);
            let (p, _) = closest_point(c, &a, &b, &d);
            if (c - p).norm_squared() < reach * reach {
                out.push(t as u32);
            }
        }
    }

    /// The contact of a sphere (centre c, radius r) with triangle t, or None when
    /// there is none or when another triangle owns the closest feature.
    #[inline]
    pub fn contact(&self, t: usize, c: &Vec3, r: f64) -> Option<WallHit> {
        let [a, b, d] = self.corners(t);
        let (p, region) = closest_point(c, &a, &b, &d);
        let cp = c - p;
        let dist2 = cp.norm_squared();
        if dist2 >= r * r {
            return None;
        }
        match region {
            Region::Face => {}
            Region::Edge(k) => {
                if !self.edge_owned[t][k] {
                    return None;
                }
                // every other triangle at this edge must find its closest point on it
                let tol2 = (1e-9 * r).powi(2);
                let (s, e) = self.edge_nb[t][k];
                for &u in &self.edge_tris[s as usize..e as usize] {
                    let [ua, ub, uc] = self.corners(u as usize);
                    let (q, ru) = closest_point(c, &ua, &ub, &uc);
                    if ru == Region::Face || (q - p).norm_squared() > tol2 {
                        return None;
                    }
                }
            }
            Region::Vertex(k) => {
                if !self.vertex_owned[t][k] {
                    return None;
                }
                // every triangle at this vertex must find its closest point at it
                let (s, e) = self.vertex_nb[self.triangles[t][k] as usize];
                for &u in &self.vertex_tris[s as usize..e as usize] {
                    if u as usize == t {
                        continue;
                    }
                    let [ua, ub, uc] = self.corners(u as usize);
                    let (q, _) = closest_point(c, &ua, &ub, &uc);
                    if q != p {
                        return None;
                    }
                }
            }
        }
        let dist = dist2.sqrt();
        let n = if dist > 1e-14 * r {
            cp / dist
        } else {
            self.normals[t]
        };
        Some(WallHit { n, overlap: r - dist, point: p, feature: t as u32 })
    }

    /// Write the mesh as a binary STL file.
    pub fn write_stl(&self, path: &Path) -> std::io::Result<()> {
        let tris: Vec<stl_io::Triangle> = (0..self.triangles.len())
            .map(|t| {
                let c = self.corners(t);
                let n = self.normals[t];
                stl_io::Triangle {
                    normal: stl_io::Normal::new([n.x as f32, n.y as f32, n.z as f32]),
                    vertices: c.map(|v| stl_io::Vertex::new([v.x as f32, v.y as f32, v.z as f32])),
                }
            })
            .collect();
        let mut f = std::io::BufWriter::new(std::fs::File::create(path)?);
        stl_io::write_stl(&mut f, tris.iter())
    }
}

/// Append two triangles for the planar quadrilateral a-b-c-d (in order) to a mesh under construction.
pub fn push_quad(v: &mut Vec<Vec3>, t: &mut Vec<[u32; 3]>, q: [Vec3; 4]) {
    let idx: Vec<u32> = q
        .iter()
        .map(|p| {
            if let Some(i) = v.iter().position(|x| (x - p).norm() < 1e-12) {
                i as u32
            } else {
                v.push(*p);
                (v.len() - 1) as u32
            }
        })
        .collect();
    t.push([idx[0], idx[1], idx[2]]);
    t.push([idx[0], idx[2], idx[3]]);
}

/// Checks before `stl_io` reads a file, for messages that name what is wrong:
/// an ASCII file (starting with `solid`) has finite numbers on its `facet
/// normal` and `vertex` lines (else the line is named); a binary file is
/// 84 + 50 n bytes for the n facets its header announces (else both sizes).
fn check_stl(name: &str, bytes: &[u8]) -> Result<(), TalusError> {
    if bytes.trim_ascii_start().starts_with(b"solid") {
        for (i, line) in String::from_utf8_lossy(bytes).lines().enumerate() {
            let t: Vec<&str> = line.split_whitespace().collect();
            let (what, nums) = match t.as_slice() {
                ["vertex", rest @ ..] => ("vertex x y z", rest),
                ["facet", "normal", rest @ ..] => ("facet normal nx ny nz", rest),
                _ => continue,
            };
            if let Some(tok) = nums.iter().find(|tok| !tok.parse::<f32>().is_ok_and(f32::is_finite)) {
                return Err(TalusError::Input(format!("{name}, line {}: `{tok}` is not a finite number (in `{what}`)", i + 1)));
            }
        }
        return Ok(());
    }
    let n = (bytes.len() >= 84).then(|| u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64);
    match n {
        Some(n) if bytes.len() as u64 == 84 + 50 * n => Ok(()),
        None => Err(TalusError::Input(format!(
            "{name}: not a readable STL file: {} bytes, shorter than a binary STL's 84-byte header, and not ASCII (does not start with `solid`)",
            bytes.len()
        ))),
        Some(n) => Err(TalusError::Input(format!(
            "{name}: binary STL: the header says {n} facets, which take 84 + 50 x {n} = {} bytes, but the file has {} bytes",
            84 + 50 * n,
            bytes.len()
        ))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square() -> Mesh {
        // unit square in z = 0 made of two triangles sharing the diagonal (0,0)-(1,1)
        let mut v = Vec::new();
        let mut t = Vec::new();
        push_quad(&mut v, &mut t, [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]);
        Mesh::new(v, t).unwrap()
    }

    fn hits(m: &Mesh, c: Vec3, r: f64) -> Vec<WallHit> {
        let feats: Vec<(u16, u32)> = (0..m.triangles.len() as u32).map(|t| (0, t)).collect();
        let mut h: Vec<Option<WallHit>> = (0..m.triangles.len()).map(|t| m.contact(t, &c, r)).collect();
        crate::walls::merge_coincident(&feats, &mut h, r);
        h.into_iter().flatten().collect()
    }

    #[test]
    fn sphere_on_shared_edge_gets_one_contact() {
        let m = square();
        for &c in &[Vec3::new(0.5, 0.5, 0.05), Vec3::new(0.3, 0.3, 0.09), Vec3::new(0.0, 0.0, 0.05)] {
            let h = hits(&m, c, 0.1);
            assert_eq!(h.len(), 1, "at {c:?}: {h:?}");
            assert!((h[0].overlap - (0.1 - c.z)).abs() < 1e-12);
        }
        // near but off the diagonal: one face contact
        let h = hits(&m, Vec3::new(0.52, 0.5, 0.05), 0.1);
        assert_eq!(h.len(), 1);
        assert!((h[0].n - Vec3::z()).norm() < 1e-12);
    }

    #[test]
    fn convex_edge_and_concave_corner() {
        // an L: floor z = 0 for x in [0, 1], wall x = 0 for z in [0, 1] (concave corner at x = z = 0 seen from x, z > 0)
        let mut v = Vec::new();
        let mut t = Vec::new();
        push_quad(&mut v, &mut t, [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]);
        push_quad(&mut v, &mut t, [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ]);
        let m = Mesh::new(v, t).unwrap();
        // in the concave corner: one contact with each face
        let h = hits(&m, Vec3::new(0.05, 0.5, 0.05), 0.1);
        assert_eq!(h.len(), 2, "{h:?}");
        // outside, around the convex side of the same edge (x < 0, z < 0): one edge contact
        let c = Vec3::new(-0.05, 0.5, -0.05);
        let h = hits(&m, c, 0.1);
        assert_eq!(h.len(), 1, "{h:?}");
        assert!((h[0].overlap - (0.1 - 0.05 * 2f64.sqrt())).abs() < 1e-12);
        // beyond the floor's free edge at x = 1: one edge contact, from its only triangle
        let h = hits(&m, Vec3::new(1.05, 0.5, 0.05), 0.1);
        assert_eq!(h.len(), 1, "{h:?}");
    }

    #[test]
    fn no_double_contact_in_a_thin_band_beside_a_shared_edge_or_vertex() {
        let m = square();
        for eps in [1e-15, 1e-13, 1e-12, 1e-11, 1e-9, 1e-7] {
            for c in [
                Vec3::new(0.5 - eps, 0.5 + eps, 0.05),
                Vec3::new(0.5 + eps, 0.5 - eps, 0.05),
                Vec3::new(eps, eps * 0.5, 0.05),
                Vec3::new(1.0 - eps, 1.0 - 0.3 * eps, 0.05),
            ] {
                let h = hits(&m, c, 0.1);
                assert_eq!(h.len(), 1, "eps {eps} at {c:?}: {h:?}");
            }
        }
    }

    #[test]
    fn fan_of_coplanar_triangles_gives_one_contact_at_the_shared_vertex() {
        // six triangles around the origin in z = 0
        let mut v = vec![Vec3::zeros()];
        for k in 0..6 {
            let a = k as f64 * std::f64::consts::PI / 3.0;
            v.push(Vec3::new(a.cos(), a.sin(), 0.0));
        }
        let t: Vec<[u32; 3]> = (0..6).map(|k| [0, 1 + k as u32, 1 + ((k + 1) % 6) as u32]).collect();
        let m = Mesh::new(v, t).unwrap();
        for c in [Vec3::new(0.0, 0.0, 0.05), Vec3::new(1e-13, -1e-13, 0.05), Vec3::new(0.01, 0.0, 0.05)] {
            let h = hits(&m, c, 0.1);
            assert_eq!(h.len(), 1, "at {c:?}: {h:?}");
        }
    }

    #[test]
    fn stl_checks_name_the_line_of_a_bad_number_and_both_sizes_of_a_short_binary() {
        let ascii = "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 inf 0\n";
        let e = check_stl("x.stl", ascii.as_bytes()).unwrap_err().to_string();
        assert_eq!(e, "x.stl, line 5: `inf` is not a finite number (in `vertex x y z`)");
        let mut bin = vec![0u8; 80];
        bin.extend(2u32.to_le_bytes());
        bin.extend([0u8; 50]);
        let e = check_stl("x.stl", &bin).unwrap_err().to_string();
        assert!(e.contains("header says 2 facets") && e.contains("184 bytes") && e.contains("has 134 bytes"), "{e}");
        bin.extend([0u8; 50]);
        assert!(check_stl("x.stl", &bin).is_ok());
    }

    #[test]
    fn degenerate_facet_is_refused() {
        let v = vec![Vec3::zeros(), Vec3::x(), Vec3::x() * 2.0];
        let e = Mesh::new(v, vec![[0, 1, 2]]).unwrap_err();
        assert!(e.contains("facet 0 is degenerate"), "{e}");
    }
}
