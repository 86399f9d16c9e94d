//! Criterion bench of mesh wall candidates from the triangle grid
//! (`Mesh::candidates_grid`, what `Mesh::candidates` uses above
//! `SCAN_MAX_TRIANGLES` triangles): 10,000 queries near the surface of the H1 hopper and its lower box as
//! one mesh of 26 triangles, and of a UV sphere of 99,500 triangles, in random
//! order and in the order of particles in storage (by cell); and the scan over
//! every triangle (`Mesh::candidates_linear`, what `candidates` did
//! before the grid) on both, over fewer queries for the sphere.
//!
//! Run: `cargo bench --bench mesh` (time per query = time per iteration / the
//! number of queries; `Throughput::Elements` gives queries per second).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use talus::dim::Vec3;
use talus::generate::hopper_meshes;
use talus::walls::Mesh;

/// The hopper and the lower box of H1 as one mesh (16 + 10 triangles).
fn h1_mesh() -> Mesh {
    let (a, b) = hopper_meshes();
    let off = a.vertices.len() as u32;
    let mut v = a.vertices.clone();
    v.extend(&b.vertices);
    let mut t = a.triangles.clone();
    t.extend(b.triangles.iter().map(|x| x.map(|k| k + off)));
    Mesh::new(v, t).unwrap()
}

/// A UV sphere of radius 0.1 m: `n_lat` bands of `n_lon` segments, 2 n_lon (n_lat - 1) triangles.
fn sphere(n_lat: usize, n_lon: usize) -> Mesh {
    talus::walls::mesh::uv_sphere(Vec3::zeros(), 0.1, n_lat, n_lon)
}

/// Particle radius and reach (radius + skin) of the queries, as in H1.
const RADIUS: f64 = 0.001;
const REACH: f64 = 0.0014;

/// n query centres: a random point of a random triangle, moved along its
/// normal by up to two radii either way.
fn queries(m: &Mesh, n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let t = rng.random_range(0..m.triangles.len());
            let [a, b, c] = m.triangles[t].map(|k| m.vertices[k as usize]);
            let (u, w) = (rng.random::<f64>(), rng.random::<f64>());
            let (u, w) = if u + w > 1.0 { (1.0 - u, 1.0 - w) } else { (u, w) };
            a + (b - a) * u + (c - a) * w + m.normals[t] * (2.0 * RADIUS * (2.0 * rng.random::<f64>() - 1.0))
        })
        .collect()
}

fn run(qs: &[Vec3], f: impl Fn(&Vec3, &mut Vec<u32>)) -> usize {
    let mut out = Vec::new();
    let mut found = 0;
    for c in qs {
        out.clear();
        f(black_box(c), &mut out);
        found += out.len();
    }
    found
}

fn bench_candidates(cr: &mut Criterion) {
    let h1 = h1_mesh();
    let fine = sphere(200, 250);
    let mut g = cr.benchmark_group("mesh_candidates");
    let fine_name = format!("sphere_{}_triangles", fine.triangles.len());
    for (name, m) in [("h1_26_triangles", &h1), (fine_name.as_str(), &fine)] {
        let qs = queries(m, 10_000, 1);
        g.throughput(Throughput::Elements(qs.len() as u64));
        g.bench_function(format!("grid/{name}"), |b| b.iter(|| run(&qs, |c, out| m.candidates_grid(c, REACH, out))));
        // in the order the list build meets them: by cell of side 2 REACH, x fastest (`StorageOrder::Cell`)
        let mut sorted = qs.clone();
        let cell = |c: &Vec3| c.map(|x| (x / (2.0 * REACH)).floor() as i64);
        sorted.sort_by_key(|c| {
            let k = cell(c);
            (k.z, k.y, k.x)
        });
        g.bench_function(format!("grid_stored_order/{name}"), |b| b.iter(|| run(&sorted, |c, out| m.candidates_grid(c, REACH, out))));
        // the scan over every triangle: 1,000 queries on the sphere (100 M box tests)
        let qs = if m.triangles.len() > 1000 { &qs[..1000] } else { &qs[..] };
        g.throughput(Throughput::Elements(qs.len() as u64));
        g.bench_function(format!("scan/{name}"), |b| b.iter(|| run(qs, |c, out| m.candidates_linear(c, REACH, out))));
    }
    g.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench_candidates
}
criterion_main!(benches);
