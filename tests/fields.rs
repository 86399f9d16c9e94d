//! Continuum fields (coarse-graining) against what must hold by construction:
//! a column of three spheres resting on a fixed one (MercuryDPM's static
//! balance test, in its units: unit diameter, unit mass, g = 1), and a settled
//! bed on a floor. Each test prints its figures.

use std::path::Path;
use talus::case::Case;
use talus::dim::Vec3;
use talus::fields::kernel::Kernel;
use talus::fields::{Averaged, Domain, Fields, Points, Sample};
use talus::sim::Simulation;

fn run(text: &str, steps: usize) -> Simulation {
    let case = Case::parse(text, Path::new("fields-test.toml")).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = Simulation::new(case).unwrap_or_else(|e| panic!("{e}"));
    // stepped here, not by a run's observers: keep the wall contacts of every step
    sim.keep_wall_contacts();
    sim.prepare().unwrap();
    for _ in 0..steps {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
    }
    sim
}

/// The fields of the simulation's present state on `n` points along z of
/// `domain` (its x-y extent is the area the profile averages over).
fn profile(sim: &Simulation, kernel: Kernel, domain: Domain, n: usize) -> Averaged {
    let p = sim.particles();
    let contacts = sim.all_contacts();
    let mut f = Fields::new(kernel, Points::Profile { axis: 2, n }, domain).unwrap();
    let own = p.owned();
    f.add(&Sample { pos: &p.pos[..own], vel: &p.vel[..own], mass: &p.mass[..own], contacts: &contacts });
    f.averaged()
}

fn shifted(d: Domain, dz: f64) -> Domain {
    Domain { lo: d.lo + Vec3::new(0.0, 0.0, dz), hi: d.hi + Vec3::new(0.0, 0.0, dz), ..d }
}

const COLUMN: &str = include_str!("../cases/static-column.toml");

/// Three unit spheres on a fixed one, at rest under g = 1: the profile's
/// density integrates to the mass per area, the stress sigma_zz integrates to
/// the virial g sum m (z_i - z_c) / A (z_c the contact with the fixed sphere),
/// and the momentum balance d sigma_zz / dz = rho g_z holds to round-off away
/// from the fixed sphere's contact, for both kernels.
#[test]
fn a_column_at_rest_balances_its_weight() {
    let sim = run(COLUMN, 40_000);
    let p = sim.particles();
    let vmax = p.vel.iter().map(|v| v.norm()).fold(0.0, f64::max);
    assert!(vmax < 1e-9, "the column has not come to rest: |v| up to {vmax:e}");
    let contacts = sim.all_contacts();
    assert_eq!(contacts.len(), 3, "two pairs and the fixed sphere: {contacts:?}");
    let base = contacts.iter().find(|c| c.wall).unwrap();
    let area = 16.0;
    let mass: f64 = p.mass.iter().sum();
    assert!((mass - 3.0).abs() < 1e-12, "unit masses: {mass}");
    let virial: f64 = (0..3).map(|i| p.mass[i] * 1.0 * (p.pos[i].z - base.point.z)).sum::<f64>() / area;
    let d = Domain { lo: Vec3::new(-2.0, -2.0, -1.0), hi: Vec3::new(2.0, 2.0, 5.0), periodic: [false; 3] };
    for kernel in [Kernel::Lucy { c: 0.5 }, Kernel::Gauss { w: 0.2 }] {
        let n = 600;
        let h = 6.0 / n as f64;
        let f = profile(&sim, kernel, d, n);
        let rho_int: f64 = f.density.iter().sum::<f64>() * h;
        let szz_int: f64 = (0..n).map(|i| f.stress(i, 2, 2)).sum::<f64>() * h;
        let mean_rho = rho_int / 3.0; // over the column's height (three diameters)
        let mean_szz = szz_int / 3.0;
        println!(
            "column, {} width {}: integral of density {rho_int:.9} kg/m^2 (mass per area {:.9}); integral of sigma_zz {szz_int:.9} (virial {virial:.9}); mean density over 3 diameters {mean_rho:.6}, mean sigma_zz {mean_szz:.6}",
            kernel.name(),
            kernel.width(),
            mass / area
        );
        assert!((rho_int - mass / area).abs() < 1e-6 * mass / area, "density integral (the midpoint rule over the profile)");
        assert!((szz_int - virial).abs() < 1e-6 * virial, "sigma_zz integral {szz_int} against the virial {virial}");
        // the balance: a central difference of the profile (the points moved by +-dz)
        let dz = 1e-4;
        let (up, down) = (profile(&sim, kernel, shifted(d, dz), n), profile(&sim, kernel, shifted(d, -dz), n));
        let rho_g_max = f.density.iter().fold(0.0f64, |m, r| m.max(r * 1.0));
        let mut worst = 0.0f64;
        for i in 0..n {
            let z = f.at[i].z;
            // away from the fixed sphere's contact point (an external force acts there)
            if (z - base.point.z).abs() <= kernel.cutoff() + 2.0 * dz {
                continue;
            }
            let div = (up.stress(i, 2, 2) - down.stress(i, 2, 2)) / (2.0 * dz);
            worst = worst.max((div - f.density[i] * -1.0).abs());
        }
        println!("  largest |d sigma_zz/dz - rho g_z| away from the base: {worst:.3e} (rho g up to {rho_g_max:.4})");
        assert!(worst < 1e-6 * rho_g_max, "momentum balance: {worst:e} against rho g up to {rho_g_max}");
    }
}

const BED: &str = r#"
[simulation]
timestep_rayleigh_fraction = 0.2
gravity = [0.0, 0.0, -9.81]
integrator = "verlet"
skin = 0.0006
domain = { lo = [0.0, 0.0, 0.0], hi = [0.012, 0.012, 0.06], periodic = ["x", "y"] }

[contact]
model = "hertz"

[[material]]
name = "grain"
youngs_modulus = 1.0e6
poisson_ratio = 0.3
density = 2500.0
restitution = 0.3
friction = 0.5

[particles]
material = "grain"
lattice = { count = 600, radius_min = 0.0007, radius_max = 0.0008, lo = [0.0008, 0.0008, 0.0008], hi_xy = [0.0112, 0.0112], spacing = 2.1, seed = 3 }

[[wall]]
name = "floor"
material = "grain"
plane = { point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }

[[phase]]
name = "settle"
duration = 1.0

[output]
interval = 0.01
contacts = true
"#;

/// A bed settled on a floor: sigma_zz between the floor and the lowest
/// centres (where only the floor's contacts cross) is the floor's force per
/// area, at each kernel width narrow enough to fit there; the floor carries
/// the bed's weight; and the bulk's mean density settles to a plateau as the
/// width shrinks from three diameters to one (the fields converge).
#[test]
fn a_settled_bed_stresses_its_floor_with_its_weight() {
    let mut sim = run(BED, 0);
    let steps = (0.5 / sim.dt()).ceil() as usize;
    for _ in 0..steps {
        sim.step().unwrap();
    }
    let p = sim.particles();
    let own = p.owned();
    let area = 0.012 * 0.012;
    let weight: f64 = p.mass[..own].iter().sum::<f64>() * 9.81;
    let floor = -sim.walls().iter().find(|w| w.name == "floor").unwrap().force.z; // the wall's load is the force on it
    println!("bed: {own} spheres weigh {weight:.6e} N; the floor carries {floor:.6e} N");
    assert!((floor - weight).abs() < 2e-3 * weight, "the bed has not settled: floor {floor} against weight {weight}");
    let zmin = (0..own).map(|i| p.pos[i].z).fold(f64::INFINITY, f64::min);
    let zc = 0.5 * zmin;
    for width in [0.2 * zmin, 0.45 * zmin] {
        let k = Kernel::Lucy { c: width };
        let d = Domain { lo: Vec3::new(0.0, 0.0, zc - 1e-6), hi: Vec3::new(0.012, 0.012, zc + 1e-6), periodic: [true, true, false] };
        let f = profile(&sim, k, d, 1);
        let szz = f.stress(0, 2, 2);
        println!("  sigma_zz at z = {zc:.4e} m (Lucy radius {width:.3e} m): {szz:.9e} Pa; floor force per area {:.9e} Pa", floor / area);
        assert!((szz - floor / area).abs() < 1e-9 * floor / area, "sigma_zz at the floor {szz} against {}", floor / area);
    }
    // the bulk's mean density (from 3 to 6 diameters up) at kernel widths of 3, 2 and 1 diameters
    let dia = 0.0015;
    let d = Domain { lo: Vec3::new(0.0, 0.0, 0.0), hi: Vec3::new(0.012, 0.012, 0.06), periodic: [true, true, false] };
    let n = 400;
    let mut means = Vec::new();
    for mult in [3.0, 2.0, 1.0] {
        let f = profile(&sim, Kernel::Gauss { w: mult * dia / 3.0 }, d, n);
        let inside: Vec<f64> = (0..n).filter(|&i| f.at[i].z > 3.0 * dia && f.at[i].z < 6.0 * dia).map(|i| f.density[i]).collect();
        let mean = inside.iter().sum::<f64>() / inside.len() as f64;
        // the weight above each height: sigma_zz at 4 diameters equals the weight of the bed above it per area, in a bed at rest
        means.push(mean);
        // at rest, sigma_zz at each height is the weight of the bed above it per area
        let h = 0.06 / n as f64;
        for z in [3.5 * dia, 5.0 * dia] {
            // (above the floor by more than the kernel's reach: none of the mass is spread below it)
            let i = (0..n).find(|&i| f.at[i].z >= z).unwrap();
            let above: f64 = f.density[i + 1..].iter().sum::<f64>() * h + 0.5 * f.density[i] * h;
            let (s, w) = (f.stress(i, 2, 2), above * 9.81);
            println!("    sigma_zz at {:.4e} m: {s:.4} Pa; the weight above per area {w:.4} Pa", f.at[i].z);
            assert!((s - w).abs() < 1e-3 * w, "sigma_zz {s} against the weight above {w}");
        }
        println!("  Gauss cut at {mult} diameters: bulk mean density {mean:.3} kg/m^3 (solid fraction {:.4})", mean / 2500.0);
    }
    let (d1, d2) = ((means[1] - means[0]).abs(), (means[2] - means[1]).abs());
    println!("  change from 3 to 2 diameters {:.3}%, from 2 to 1 {:.3}%", 100.0 * d1 / means[1], 100.0 * d2 / means[2]);
    assert!(d2 < 0.02 * means[2] && d1 < 0.05 * means[1], "the bulk density does not settle as the width shrinks: {means:?}");
}

/// `[output.fields]` refuses what it cannot do, naming the key and the value.
#[test]
fn bad_field_requests_are_refused_naming_the_key() {
    for (edit, msg) in [
        (("width = 0.2", "width = -0.2"), "output.fields.width = -0.2: the kernel's width must be a positive length"),
        (("profile = \"z\"", "profile = \"q\""), "output.fields.profile = \"q\": must be \"x\", \"y\" or \"z\""),
        (("profile = \"z\"", "profile = \"z\"\ngrid = [2, 2, 2]"), "output.fields.grid: a profile or a grid, not both"),
        (("[output.fields]", "[output.fields]\nkernel = \"box\""), "output.fields.kernel = \"box\": must be \"gauss\" or \"lucy\""),
        (("interval = 1.0\nfrom", "interval = 0.0\nfrom"), "output.fields.interval = 0: must be a positive time (s)"),
    ] {
        let text = COLUMN.replacen(edit.0, edit.1, 1);
        assert_ne!(text, COLUMN, "{edit:?}");
        let e = Case::parse(&text, Path::new("column.toml")).err().unwrap_or_else(|| panic!("{edit:?} accepted"));
        assert!(e.to_string().contains(msg), "{edit:?}: {e}");
    }
}
