//! Criterion bench of the continuum fields (`talus::fields`): one sample of
//! 100,000 particles and 500,000 contacts (random, in a 0.1 m box, particles
//! of 2 mm diameter, branches of one diameter), on a profile of 200 points
//! and on a 40 x 40 x 40 grid, with a Gaussian kernel of one diameter and
//! Lucy's of two. What `talus fields` does per snapshot, and what
//! `[output.fields]` adds to a run per sample (besides the gather).
//!
//! Run: `cargo bench --bench fields` (the time per iteration is one sample).

use criterion::{criterion_group, criterion_main, Criterion};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use talus::dim::Vec3;
use talus::fields::kernel::Kernel;
use talus::fields::{ContactRecord, Domain, Fields, Points, Sample};

const N: usize = 100_000;
const CONTACTS: usize = 500_000;
const D: f64 = 0.002;

struct Data {
    pos: Vec<Vec3>,
    vel: Vec<Vec3>,
    mass: Vec<f64>,
    contacts: Vec<ContactRecord>,
}

fn data() -> Data {
    let mut r = ChaCha8Rng::seed_from_u64(1);
    let mut v3 = |s: f64, o: f64| Vec3::new(o + s * r.random::<f64>(), o + s * r.random::<f64>(), o + s * r.random::<f64>());
    let pos: Vec<Vec3> = (0..N).map(|_| v3(0.1, 0.0)).collect();
    let vel: Vec<Vec3> = (0..N).map(|_| v3(0.2, -0.1)).collect();
    let mass = vec![1e-5; N];
    let mut r = ChaCha8Rng::seed_from_u64(2);
    let contacts = (0..CONTACTS)
        .map(|k| {
            let a = k % N;
            let dir = Vec3::new(r.random::<f64>() - 0.5, r.random::<f64>() - 0.5, r.random::<f64>() - 0.5).normalize();
            let branch = dir * D;
            ContactRecord {
                a: a as u64,
                partner: ((a + 1) % N) as u64,
                wall: false,
                force: dir * 1e-3,
                point: pos[a] - branch * 0.5,
                centre: pos[a],
                branch,
            }
        })
        .collect();
    Data { pos, vel, mass, contacts }
}

fn bench(c: &mut Criterion) {
    let d = data();
    let domain = Domain { lo: Vec3::zeros(), hi: Vec3::new(0.1, 0.1, 0.1), periodic: [false; 3] };
    let sample = Sample { pos: &d.pos, vel: &d.vel, mass: &d.mass, contacts: &d.contacts };
    let mut g = c.benchmark_group("fields");
    g.sample_size(10);
    for (name, kernel, points) in [
        ("profile_200_gauss_1d", Kernel::Gauss { w: D / 3.0 }, Points::Profile { axis: 2, n: 200 }),
        ("grid_40_gauss_1d", Kernel::Gauss { w: D / 3.0 }, Points::Grid { n: [40, 40, 40] }),
        ("grid_40_lucy_2d", Kernel::Lucy { c: 2.0 * D }, Points::Grid { n: [40, 40, 40] }),
    ] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let mut f = Fields::new(kernel, points.clone(), domain).unwrap();
                f.add(black_box(&sample));
                black_box(f.averaged().density[0])
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
