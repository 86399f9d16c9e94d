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
//!
//! Wall candidates come from a uniform grid over the triangles (`TriangleGrid`):
//! a query visits only the cells its box overlaps, and returns exactly what a
//! scan over every triangle would (the same triangles, in ascending order).
//! Meshes of a few triangles are scanned, which is faster there.

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

/// A triangle mesh wall: vertices, triangles, their adjacency and feature
/// owners, bounding boxes and the grid that finds candidates. Vertices move only
/// through [`Mesh::translate`] and [`Mesh::rotate`] (which keep boxes and grid in
/// step). Serialised
/// without its grid (the checkpoint layout is unchanged); deserialising builds it.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(from = "MeshFields")]
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
    /// The triangles binned into a uniform grid, for `candidates`.
    #[serde(skip_serializing)]
    grid: TriangleGrid,
}

/// The serialised fields of a [`Mesh`] (all but the grid, in the same order).
#[derive(Deserialize)]
struct MeshFields {
    vertices: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<Vec3>,
    edge_owned: Vec<[bool; 3]>,
    vertex_owned: Vec<[bool; 3]>,
    edge_nb: Vec<[(u32, u32); 3]>,
    edge_tris: Vec<u32>,
    vertex_nb: Vec<(u32, u32)>,
    vertex_tris: Vec<u32>,
    aabb: Vec<(Vec3, Vec3)>,
    bounds: (Vec3, Vec3),
}

impl From<MeshFields> for Mesh {
    fn from(f: MeshFields) -> Mesh {
        let grid = TriangleGrid::build(&f.aabb, f.bounds);
        Mesh {
            vertices: f.vertices,
            triangles: f.triangles,
            normals: f.normals,
            edge_owned: f.edge_owned,
            vertex_owned: f.vertex_owned,
            edge_nb: f.edge_nb,
            edge_tris: f.edge_tris,
            vertex_nb: f.vertex_nb,
            vertex_tris: f.vertex_tris,
            aabb: f.aabb,
            bounds: f.bounds,
            grid,
        }
    }
}

/// Meshes of at most this many triangles find candidates by scanning them all:
/// for the 26 triangles of the H1 hopper and box the scan takes 0.12 us per
/// query, the grid 0.18 (`cargo bench --bench mesh`).
pub const SCAN_MAX_TRIANGLES: usize = 32;

/// Most cells a [`TriangleGrid`] may have, whatever the triangle count (4 Mi
/// cells: 16 MiB of offsets).
const GRID_MAX_CELLS: usize = 1 << 22;

/// The triangles of a mesh binned into a uniform grid of cubic cells: each
/// triangle is listed in every cell its bounding box overlaps, and
/// `tris[start[c]..start[c + 1]]` holds cell c's triangles in ascending order
/// (cells in x-fastest order, cell (0, 0, 0) with its low corner at `origin`).
///
/// Cell size: the median over the triangles of the longest side of their
/// bounding boxes (a triangle then overlaps at most 2 cells along each axis),
/// grown by factors of 1.5 until the grid has at most min(4 n, 2^22) cells and
/// the triangles' cell memberships add up to at most 16 n (n triangles). Growing
/// ends at the latest when one cell covers the mesh (n memberships), so a long
/// thin mesh, a single huge triangle or a few huge triangles among many small
/// ones cost O(n) memory: at most 4 n + 1 offsets and 16 n entries (u32 each).
///
/// Translating the mesh shifts `origin` by the same vector; the rounding by
/// which the triangles' boxes and the origin may part over many shifts is
/// bounded in `drift` and added to the margin of every query (a shift that lets
/// it pass an eighth of a cell re-bins the triangles).
#[derive(Clone, Debug)]
struct TriangleGrid {
    origin: Vec3,
    /// Cell size (infinite when one cell covers the mesh).
    h: f64,
    inv_h: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    tris: Vec<u32>,
    /// Largest |coordinate| of the origin and the triangles' boxes at binning.
    scale0: f64,
    /// Bound on how far translations' rounding has moved any triangle box
    /// relative to the origin since binning.
    drift: f64,
}

impl TriangleGrid {
    /// Bin the triangles with boxes `aabb` (whole mesh: `bounds`); the rule for
    /// the cell size is in the type's documentation.
    fn build(aabb: &[(Vec3, Vec3)], bounds: (Vec3, Vec3)) -> TriangleGrid {
        let nt = aabb.len();
        let origin = if bounds.0.iter().all(|x| x.is_finite()) { bounds.0 } else { Vec3::zeros() };
        let ext = bounds.1 - bounds.0;
        let scale0 = bounds.0.amax().max(bounds.1.amax());
        let mut g = TriangleGrid {
            origin,
            h: f64::INFINITY,
            inv_h: 0.0,
            dims: [1; 3],
            start: vec![0, 0],
            tris: Vec::new(),
            scale0,
            drift: 0.0,
        };
        if nt == 0 || !ext.iter().all(|x| x.is_finite()) {
            g.fill(aabb);
            return g;
        }
        let mut sides: Vec<f64> = aabb.iter().map(|(lo, hi)| (hi - lo).max()).collect();
        let (_, &mut median, _) = sides.select_nth_unstable_by(nt / 2, f64::total_cmp);
        let mut h = if median > 0.0 { median } else { ext.max() };
        let cell_cap = (4 * nt).min(GRID_MAX_CELLS);
        let entry_cap = 16 * nt as u64;
        // ends: h grows until one cell covers the (finite) extent
        while h > 0.0 && h.is_finite() {
            let dims = ext.map(|e| (e / h).ceil().max(1.0));
            let cells = dims.x * dims.y * dims.z;
            if cells <= 1.0 {
                break;
            }
            if cells <= cell_cap as f64 {
                g.set_cells(h, [dims.x as usize, dims.y as usize, dims.z as usize]);
                let entries: u64 =
                    aabb.iter().map(|b| g.span(b).iter().map(|&(a, z)| (z - a + 1) as u64).product::<u64>()).sum();
                if entries <= entry_cap {
                    g.fill(aabb);
                    return g;
                }
            }
            h *= 1.5;
        }
        g.set_cells(f64::INFINITY, [1; 3]);
        g.fill(aabb);
        g
    }

    fn set_cells(&mut self, h: f64, dims: [usize; 3]) {
        self.h = h;
        self.inv_h = if dims == [1; 3] { 0.0 } else { 1.0 / h };
        self.dims = dims;
    }

    /// The cell index along `axis` of coordinate x, clamped to the grid
    /// (monotone in x; NaN gives 0).
    #[inline(always)]
    fn index(&self, axis: usize, x: f64) -> usize {
        let f = ((x - self.origin[axis]) * self.inv_h).floor();
        let top = self.dims[axis] - 1;
        if !(f > 0.0) {
            0
        } else if f >= top as f64 {
            top
        } else {
            f as usize
        }
    }

    /// The range of cells (first, last) along each axis that box b overlaps.
    #[inline(always)]
    fn span(&self, b: &(Vec3, Vec3)) -> [(usize, usize); 3] {
        std::array::from_fn(|k| (self.index(k, b.0[k]), self.index(k, b.1[k])))
    }

    /// Call f with every cell that box b overlaps.
    #[inline(always)]
    fn for_cells(&self, b: &(Vec3, Vec3), mut f: impl FnMut(usize)) {
        let [(x0, x1), (y0, y1), (z0, z1)] = self.span(b);
        for k in z0..=z1 {
            for j in y0..=y1 {
                for i in x0..=x1 {
                    f(i + self.dims[0] * (j + self.dims[1] * k));
                }
            }
        }
    }

    /// Count, then list, every triangle in the cells its box overlaps (in
    /// triangle order, so each cell's list is ascending).
    fn fill(&mut self, aabb: &[(Vec3, Vec3)]) {
        let cells = self.dims.iter().product::<usize>();
        let mut start = vec![0u32; cells + 1];
        for b in aabb {
            self.for_cells(b, |c| start[c + 1] += 1);
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let mut next = start.clone();
        let mut tris = vec![0u32; start[cells] as usize];
        for (t, b) in aabb.iter().enumerate() {
            self.for_cells(b, |c| {
                tris[next[c] as usize] = t as u32;
                next[c] += 1;
            });
        }
        self.start = start;
        self.tris = tris;
    }
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
        let n = triangles.len();
        Mesh::new(vertices, triangles).map_err(|e| {
            // where the facet is in the file: its `facet` line (ASCII), or its bytes (binary)
            let what = match e.facet {
                Some(t) => format!(", {}: the facet {}", facet_in_file(&bytes, t, n), e.message),
                None => format!(": {}", e.message),
            };
            TalusError::Input(format!("{name}{what}"))
        })
    }

    /// Build a mesh from vertices and triangles; checks for non-finite vertices and degenerate facets.
    pub fn new(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        let bad = |facet: Option<usize>, message: String| Err(MeshError { facet, message });
        for (i, v) in vertices.iter().enumerate() {
            if !(v.x.is_finite() && v.y.is_finite() && v.z.is_finite()) {
                return bad(None, format!("vertex {i} is not finite: {v:?}"));
            }
        }
        if triangles.len() > (u32::MAX / 16) as usize {
            return bad(None, format!("{} facets: more than the {} a mesh may have", triangles.len(), u32::MAX / 16));
        }
        if let Some((t, tri)) = triangles.iter().enumerate().find(|(_, tri)| tri.iter().any(|&k| k as usize >= vertices.len())) {
            return bad(Some(t), format!("names vertex {} of {} vertices", tri.iter().max().copied().unwrap_or(0), vertices.len()));
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
                return bad(Some(t), format!(
                    "is degenerate (zero area): vertices ({:.6e}, {:.6e}, {:.6e}), ({:.6e}, {:.6e}, {:.6e}), ({:.6e}, {:.6e}, {:.6e})",
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
            grid: TriangleGrid::build(&[], (Vec3::zeros(), Vec3::zeros())),
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
        self.grid = TriangleGrid::build(&self.aabb, self.bounds);
    }

    /// Turn the mesh by `rot` about `center`: vertices and normals; boxes and
    /// grid are made anew (a turning mesh's triangles change cells).
    pub fn rotate(&mut self, center: Vec3, rot: &nalgebra::Rotation3<f64>) {
        for v in &mut self.vertices {
            *v = center + rot * (*v - center);
        }
        for n in &mut self.normals {
            *n = rot * *n;
        }
        self.update_boxes();
    }

    /// Move the mesh by d: vertices, boxes and the grid's origin (the triangles
    /// stay in their cells; see `TriangleGrid` in mesh.rs for the rounding).
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
        let g = &mut self.grid;
        g.origin += d;
        // each box coordinate and the origin's are rounded once (half an ulp each)
        let scale = g.origin.amax().max(self.bounds.0.amax()).max(self.bounds.1.amax());
        g.drift += f64::EPSILON * (scale + 2.0 * d.amax());
        if g.drift > 0.125 * g.h {
            self.grid = TriangleGrid::build(&self.aabb, self.bounds);
        }
    }

    #[inline(always)]
    fn outside(lo: &Vec3, hi: &Vec3, c: &Vec3, reach: f64) -> bool {
        c.x < lo.x - reach || c.x > hi.x + reach || c.y < lo.y - reach || c.y > hi.y + reach || c.z < lo.z - reach || c.z > hi.z + reach
    }

    #[inline(always)]
    fn corners(&self, t: usize) -> [Vec3; 3] {
        self.triangles[t].map(|k| self.vertices[k as usize])
    }

    /// Triangles whose distance from c is below `reach`, appended to `out` in
    /// ascending order: from the grid ([`Mesh::candidates_grid`]), or for a mesh
    /// of at most [`SCAN_MAX_TRIANGLES`] triangles from a scan of all of them
    /// ([`Mesh::candidates_linear`]). Both give the same triangles.
    #[inline]
    pub fn candidates(&self, c: &Vec3, reach: f64, out: &mut Vec<u32>) {
        if self.triangles.len() <= SCAN_MAX_TRIANGLES {
            self.candidates_linear(c, reach, out);
        } else {
            self.candidates_grid(c, reach, out);
        }
    }

    /// [`Mesh::candidates`] from the grid: only the triangles listed in the
    /// cells that the box c +- (reach + margin) overlaps are tested (margin: a
    /// bound on rounding, see `TriangleGrid`); each is tested as
    /// [`Mesh::candidates_linear`] tests it, so both give the same triangles.
    #[doc(hidden)]
    pub fn candidates_grid(&self, c: &Vec3, reach: f64, out: &mut Vec<u32>) {
        if Self::outside(&self.bounds.0, &self.bounds.1, c, reach) {
            return;
        }
        let g = &self.grid;
        // A box that passes the test below overlaps the query box in exact
        // arithmetic up to a few roundings of coordinates of size `scale`; the
        // margin covers four times that, plus the translations' drift.
        let scale = g.scale0 + g.origin.amax() + self.bounds.0.amax().max(self.bounds.1.amax()) + c.amax() + reach;
        let m = reach + g.drift + 4.0 * f64::EPSILON * scale;
        let lo: [usize; 3] = std::array::from_fn(|k| g.index(k, c[k] - m));
        let hi: [usize; 3] = std::array::from_fn(|k| g.index(k, c[k] + m));
        let first = out.len();
        let mut cells_with_hits = 0;
        for k in lo[2]..=hi[2] {
            for j in lo[1]..=hi[1] {
                let row = g.dims[0] * (j + g.dims[1] * k);
                for i in lo[0]..=hi[0] {
                    let cell = row + i;
                    let before = out.len();
                    for &t in &g.tris[g.start[cell] as usize..g.start[cell + 1] as usize] {
                        let (blo, bhi) = &self.aabb[t as usize];
                        if !Self::outside(blo, bhi, c, reach) {
                            out.push(t);
                        }
                    }
                    cells_with_hits += (out.len() > before) as usize;
                }
            }
        }
        // one cell's list is ascending; several may share triangles
        if cells_with_hits > 1 {
            out[first..].sort_unstable();
        }
        let mut kept = first;
        let mut prev = None;
        for k in first..out.len() {
            let t = out[k];
            if prev == Some(t) {
                continue;
            }
            prev = Some(t);
            if self.within_reach(t as usize, c, reach) {
                out[kept] = t;
                kept += 1;
            }
        }
        out.truncate(kept);
    }

    /// For a block of spheres centred in the box `lo..hi` with reach at most
    /// `reach` (radius plus skin): the triangles any of them may have as
    /// candidates, ascending, in `out` (none: `out` is left empty), where the
    /// mesh is scanned ([`SCAN_MAX_TRIANGLES`]); false where it uses its grid
    /// (each sphere is then looked up alone). A triangle is left out only
    /// where every sphere of the box fails its bounding-box test: the tests
    /// below compare the box's far side with the same bound less the largest
    /// reach, and a rounded difference is monotone in what it subtracts.
    pub fn near_box(&self, lo: &Vec3, hi: &Vec3, reach: f64, out: &mut Vec<u32>) -> bool {
        out.clear();
        if self.triangles.len() > SCAN_MAX_TRIANGLES {
            return false;
        }
        let apart = |blo: &Vec3, bhi: &Vec3| {
            (0..3).any(|k| hi[k] < blo[k] - reach || lo[k] > bhi[k] + reach)
        };
        if apart(&self.bounds.0, &self.bounds.1) {
            return true;
        }
        out.extend(self.aabb.iter().enumerate().filter(|(_, (blo, bhi))| !apart(blo, bhi)).map(|(t, _)| t as u32));
        true
    }

    /// [`Mesh::candidates`] of a sphere of a block, testing only `among`
    /// (from [`Mesh::near_box`] of a box holding c, with a reach at least
    /// this one): each tested as [`Mesh::candidates_linear`] tests it, so the
    /// same triangles in the same order.
    #[inline]
    pub fn candidates_among(&self, c: &Vec3, reach: f64, among: &[u32], out: &mut Vec<u32>) {
        if !among.is_empty() {
            self.scan(c, reach, among.iter().copied(), out);
        }
    }

    /// The candidates among `tris`, in their order: every search's
    /// triangles after the mesh's bounding box.
    #[inline(always)]
    fn scan(&self, c: &Vec3, reach: f64, tris: impl Iterator<Item = u32>, out: &mut Vec<u32>) {
        if Self::outside(&self.bounds.0, &self.bounds.1, c, reach) {
            return;
        }
        out.extend(tris.filter(|&t| {
            let (lo, hi) = &self.aabb[t as usize];
            !Self::outside(lo, hi, c, reach) && self.within_reach(t as usize, c, reach)
        }));
    }

    /// Whether triangle t's closest point to c is nearer than `reach`: the
    /// test after the bounding box in every search (scan, block or grid), so
    /// all give the same triangles.
    #[inline(always)]
    fn within_reach(&self, t: usize, c: &Vec3, reach: f64) -> bool {
        let [a, b, d] = self.corners(t);
        let (p, _) = closest_point(c, &a, &b, &d);
        (c - p).norm_squared() < reach * reach
    }

    /// [`Mesh::candidates`] by a scan over every triangle's bounding box (the
    /// reference the grid is tested and benchmarked against).
    #[doc(hidden)]
    pub fn candidates_linear(&self, c: &Vec3, reach: f64, out: &mut Vec<u32>) {
        self.scan(c, reach, 0..self.triangles.len() as u32, out);
    }

    /// Number of cells of the triangle grid and number of (cell, triangle)
    /// entries in it (for tests of its memory bound).
    #[doc(hidden)]
    pub fn grid_size(&self) -> (usize, usize) {
        (self.grid.start.len() - 1, self.grid.tris.len())
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

/// Why a mesh cannot be made: the facet at fault (its index, from 0), if one
/// is, and what is wrong ("facet 3 is degenerate ...": `message` is the part
/// after the facet's name).
#[derive(Debug, Clone, PartialEq)]
pub struct MeshError {
    pub facet: Option<usize>,
    pub message: String,
}

impl std::fmt::Display for MeshError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.facet {
            Some(t) => write!(f, "facet {t} {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

/// Where facet `t` (from 0) of an STL file's `n` is: in an ASCII file the line
/// of its `facet normal` (from 1), in a binary one its 50 bytes.
fn facet_in_file(bytes: &[u8], t: usize, n: usize) -> String {
    if bytes.trim_ascii_start().starts_with(b"solid") {
        let line = String::from_utf8_lossy(bytes)
            .lines()
            .enumerate()
            .filter(|(_, l)| l.trim_start().starts_with("facet"))
            .nth(t)
            .map(|(i, _)| i + 1);
        match line {
            Some(l) => format!("line {l} (facet {} of {n})", t + 1),
            None => format!("facet {} of {n}", t + 1),
        }
    } else {
        let at = 84 + 50 * t;
        format!("facet {} of {n} (bytes {at}-{})", t + 1, at + 49)
    }
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

/// A UV sphere: `n_lat` bands of `n_lon` segments (2 n_lon (n_lat - 1)
/// triangles), for the tests and the mesh bench.
#[doc(hidden)]
pub fn uv_sphere(center: Vec3, radius: f64, n_lat: usize, n_lon: usize) -> Mesh {
    let mut v = vec![center + Vec3::z() * radius, center - Vec3::z() * radius];
    for i in 1..n_lat {
        let th = std::f64::consts::PI * i as f64 / n_lat as f64;
        for j in 0..n_lon {
            let ph = 2.0 * std::f64::consts::PI * j as f64 / n_lon as f64;
            v.push(center + radius * Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()));
        }
    }
    let ring = |i: usize, j: usize| (2 + (i - 1) * n_lon + j % n_lon) as u32;
    let mut t = Vec::new();
    for j in 0..n_lon {
        t.push([0, ring(1, j), ring(1, j + 1)]);
        t.push([1, ring(n_lat - 1, j + 1), ring(n_lat - 1, j)]);
    }
    for i in 1..n_lat - 1 {
        for j in 0..n_lon {
            t.push([ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)]);
            t.push([ring(i, j), ring(i + 1, j + 1), ring(i, j + 1)]);
        }
    }
    Mesh::new(v, t).unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

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

    /// Separate triangles of sizes from 1e-3 to 1 times the box (stretched along
    /// the axes by `aspect`), centred in the box of side `size` at the origin.
    fn soup(rng: &mut ChaCha8Rng, n: usize, size: f64, aspect: Vec3) -> Option<Mesh> {
        let mut v = Vec::new();
        let mut t = Vec::new();
        for k in 0..n {
            let centre = Vec3::from_fn(|_, _| size * (rng.random::<f64>() - 0.5));
            let s = size * 10f64.powf(-3.0 * rng.random::<f64>());
            for _ in 0..3 {
                v.push((centre + Vec3::from_fn(|_, _| s * (rng.random::<f64>() - 0.5))).component_mul(&aspect));
            }
            t.push([3 * k as u32, 3 * k as u32 + 1, 3 * k as u32 + 2]);
        }
        Mesh::new(v, t).ok()
    }

    /// Query centres: near a triangle (a point of it moved by up to twice the
    /// reach), in the mesh's box, or on a box face of a triangle pushed out by
    /// exactly the reach (the edge of the bounding-box test).
    fn check_against_scan(m: &Mesh, rng: &mut ChaCha8Rng, queries: usize) {
        let (blo, bhi) = m.bounds;
        let size = (bhi - blo).max();
        let mut out = vec![7u32, 3];
        let mut want = vec![7u32, 3];
        for q in 0..queries {
            let reach = size * 10f64.powf(-4.0 + 4.3 * rng.random::<f64>());
            let t = rng.random_range(0..m.triangles.len());
            let [a, b, d] = m.corners(t);
            let (u, w) = (rng.random::<f64>(), rng.random::<f64>());
            let (u, w) = if u + w > 1.0 { (1.0 - u, 1.0 - w) } else { (u, w) };
            let on = a + (b - a) * u + (d - a) * w;
            let c = match q % 3 {
                0 => on + Vec3::from_fn(|_, _| 2.0 * reach * (2.0 * rng.random::<f64>() - 1.0)),
                1 => blo + (bhi - blo).component_mul(&Vec3::from_fn(|_, _| 1.2 * rng.random::<f64>() - 0.1)),
                _ => {
                    let k = rng.random_range(0..3);
                    let mut c = on;
                    c[k] = if rng.random::<bool>() { m.aabb[t].1[k] + reach } else { m.aabb[t].0[k] - reach };
                    c
                }
            };
            out.truncate(2);
            want.truncate(2);
            m.candidates_grid(&c, reach, &mut out);
            m.candidates_linear(&c, reach, &mut want);
            assert_eq!(out, want, "query {q} at {c:?}, reach {reach:e}");
            // a block's narrowing (a small mesh): c in a box with another
            // centre up to two reaches off, whose reach is up to twice c's
            let other = c + Vec3::from_fn(|_, _| 2.0 * reach * (2.0 * rng.random::<f64>() - 1.0));
            let mut near = vec![5u32];
            if m.near_box(&c.inf(&other), &c.sup(&other), reach * (1.0 + rng.random::<f64>()), &mut near) {
                out.truncate(2);
                m.candidates_among(&c, reach, &near, &mut out);
                assert_eq!(out, want, "query {q} at {c:?} in a block, reach {reach:e}");
            } else {
                assert!(m.triangles.len() > SCAN_MAX_TRIANGLES && near.is_empty());
            }
        }
    }

    fn moved(m: &Mesh, rng: &mut ChaCha8Rng, steps: usize, step: f64) -> Mesh {
        let mut m = m.clone();
        let d = Vec3::from_fn(|_, _| step * (2.0 * rng.random::<f64>() - 1.0));
        for _ in 0..steps {
            m.translate(d);
        }
        m
    }

    #[test]
    fn grid_candidates_equal_a_scan_of_every_triangle_for_random_and_moved_meshes() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut meshes = vec![uv_sphere(Vec3::new(0.3, -0.2, 1.0), 0.1, 40, 60), uv_sphere(Vec3::zeros(), 1e-3, 3, 3), square()];
        let (hopper, lower) = crate::generate::hopper_meshes();
        meshes.push(hopper);
        meshes.push(lower);
        for k in 0..24 {
            let n = [1, 2, 5, 40, 300][k % 5];
            let size = 10f64.powf(-3.0 + 4.0 * rng.random::<f64>());
            let aspect = if k % 3 == 0 { Vec3::new(1.0, 1e-2, 1e-3) } else { Vec3::repeat(1.0) };
            meshes.extend(soup(&mut rng, n, size, aspect));
        }
        for m in &meshes {
            let size = (m.bounds.1 - m.bounds.0).max();
            check_against_scan(m, &mut rng, 400);
            // moved along with its wall, step by step and far away
            check_against_scan(&moved(m, &mut rng, 2000, 1e-4 * size), &mut rng, 400);
            check_against_scan(&moved(m, &mut rng, 3, 1e3 * size), &mut rng, 400);
            // so far that the rounding of the moves re-bins the triangles
            let far = moved(m, &mut rng, 3, 1e15 * size);
            assert!(far.grid.drift == 0.0 || far.grid.dims == [1; 3], "not re-binned: {:?}", far.grid.dims);
            check_against_scan(&far, &mut rng, 400);
        }
    }

    #[test]
    fn grid_memory_is_bounded_for_a_huge_triangle_a_thin_strip_and_mixed_sizes() {
        let huge = Mesh::new(vec![Vec3::zeros(), Vec3::x() * 1e6, Vec3::new(0.0, 1e6, 1e6)], vec![[0, 1, 2]]).unwrap();
        // a strip 100 m long and 1 cm wide of 20,000 triangles, with one 100 m triangle across it
        let mut v = Vec::new();
        let mut t = Vec::new();
        for i in 0..=10_000u32 {
            v.push(Vec3::new(0.01 * i as f64, 0.0, 0.0));
            v.push(Vec3::new(0.01 * i as f64, 0.01, 1e-3 * (i % 2) as f64));
        }
        for i in 0..10_000u32 {
            t.push([2 * i, 2 * i + 2, 2 * i + 3]);
            t.push([2 * i, 2 * i + 3, 2 * i + 1]);
        }
        let strip = Mesh::new(v.clone(), t.clone()).unwrap();
        v.extend([Vec3::new(0.0, -50.0, -50.0), Vec3::new(100.0, -50.0, 50.0), Vec3::new(50.0, 50.0, 0.0)]);
        t.push([20_002, 20_003, 20_004]);
        let mixed = Mesh::new(v, t).unwrap();
        for m in [&huge, &strip, &mixed] {
            let n = m.triangles.len();
            let (cells, entries) = m.grid_size();
            assert!(cells <= 4 * n && entries <= 16 * n, "{n} triangles: {cells} cells, {entries} entries");
        }
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        check_against_scan(&huge, &mut rng, 200);
        check_against_scan(&strip, &mut rng, 2000);
        check_against_scan(&mixed, &mut rng, 2000);
    }

    #[test]
    fn a_mesh_read_back_from_a_checkpoint_has_the_same_bytes_and_candidates() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut m = uv_sphere(Vec3::zeros(), 1.0, 20, 30);
        m.translate(Vec3::new(0.1, 0.0, -0.3));
        let bytes = bincode::serialize(&m).unwrap();
        let back: Mesh = bincode::deserialize(&bytes).unwrap();
        assert_eq!(bincode::serialize(&back).unwrap(), bytes);
        assert_eq!(back.grid_size(), uv_sphere(Vec3::zeros(), 1.0, 20, 30).grid_size());
        check_against_scan(&back, &mut rng, 1000);
    }

    #[test]
    fn degenerate_facet_is_refused() {
        let v = vec![Vec3::zeros(), Vec3::x(), Vec3::x() * 2.0];
        let e = Mesh::new(v, vec![[0, 1, 2]]).unwrap_err().to_string();
        assert!(e.contains("facet 0 is degenerate"), "{e}");
    }
}
