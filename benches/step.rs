//! Criterion benches: the force sweep, a full step and a neighbour-list build on a
//! settled H1-small bed,
//! and the cost per particle-step from 5,000 to 100,000 particles in a packed
//! bed (linear scaling shows as a flat time per particle-step).
//!
//! Run: `cargo bench --bench step` (criterion's report gives time per step and,
//! through `Throughput::Elements`, particle-steps per second).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::path::Path;
use talus::builder::CaseBuilder;
use talus::case::{Case, ContactSection, LatticeSection, ModelName, PhaseSection, TimeStep, WallSection};
use talus::dim::Dimension;
use talus::material::Material;
use talus::sim::Simulation;

fn h1_small_settled() -> Simulation {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let path = root.join("cases/H1-small.toml");
    let case = Case::load(&path).unwrap();
    let mut sim = Simulation::new(case).unwrap();
    // fill until the pile has settled (the KE criterion), as the fill phase does
    while sim.phase() == 0 && sim.state().settle_end.is_none() {
        sim.step().unwrap();
        sim.advance_phase().unwrap();
    }
    sim
}

fn packed_bed(n_side_xy: usize, layers: usize) -> Simulation {
    let r = 0.001;
    let half = n_side_xy as f64 * r;
    let (lo, hi, top) = (-half - 0.01, half + 0.01, 2.0 * r * layers as f64 + 0.01);
    let lattice = LatticeSection {
        count: n_side_xy * n_side_xy * layers,
        radius_min: r,
        radius_max: r,
        lo: [-half, -half, 0.0],
        hi_xy: [half + 1e-9, half + 1e-9],
        spacing: 2.0,
        seed: 1,
    };
    let m = Material { name: "m".into(), youngs_modulus: 1.0e6, poisson_ratio: 0.3, density: 2500.0, restitution: 0.5, friction: 0.4, rolling_friction: 0.0 };
    let case = CaseBuilder::new(Dimension::Three)
        .timestep(TimeStep::RayleighFraction(0.2))
        .gravity([0.0, 0.0, -9.81])
        .skin(0.0004)
        .domain([lo, lo, -0.001], [hi, hi, top])
        .contact(ContactSection::new(ModelName::Hertz))
        .material(m)
        .lattice("m", lattice)
        .wall(WallSection::plane("floor", "m", [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]))
        .phase(PhaseSection::new("run", 100.0))
        .build(Path::new("packed.toml"))
        .unwrap();
    let mut sim = Simulation::new(case).unwrap();
    for _ in 0..200 {
        sim.step().unwrap();
    }
    sim
}

fn bench_h1(c: &mut Criterion) {
    let mut sim = h1_small_settled();
    let n = sim.particles().len() as u64;
    let mut g = c.benchmark_group("h1_small_settled");
    g.throughput(Throughput::Elements(n));
    g.bench_function("force_sweep", |b| {
        b.iter(|| sim.force_sweep())
    });
    g.bench_function("full_step", |b| b.iter(|| sim.step().unwrap()));
    // one neighbour-list build of the settled pile (history carried over by ids)
    let st = sim.state();
    let (p, walls, mut nl) = (st.p.clone(), st.walls.clone(), st.nl.clone());
    g.bench_function("list_build", |b| b.iter(|| nl.build(&p, &walls)));
    g.finish();
}

fn bench_scaling(c: &mut Criterion) {
    let mut g = c.benchmark_group("scaling_packed_bed");
    g.sample_size(10);
    // 20 layers; 5k, 20k, 50k, 100k particles
    for side in [16usize, 32, 50, 71] {
        let mut sim = packed_bed(side, 20);
        let n = sim.particles().len();
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| b.iter(|| sim.step().unwrap()));
    }
    g.finish();
}

criterion_group!(benches, bench_h1, bench_scaling);
criterion_main!(benches);
