//! Laws that pull (dmt, jkr) against their closed forms, run through the
//! whole engine: a sphere on a flat wall pulled off quasi-statically (the
//! wall withdraws slowly from a sphere too heavy to follow) measures the
//! pull-off force 4 pi gamma R (DMT) and 3 pi gamma R (JKR, after going on
//! beyond touching) within 1%, R* = R against a flat wall.

use std::f64::consts::PI;
use std::path::Path;
use talus::case::Case;
use talus::sim::Simulation;

const R: f64 = 1e-3;
const GAMMA: f64 = 0.05;

/// The wall's largest pull on the sphere (N) as it withdraws at 1e-4 m/s,
/// the sphere starting 1e-6 m into it; and the step it let go.
fn pull_off(model: &str) -> (f64, u64) {
    let text = format!(
        r#"
[simulation]
timestep = 1e-6
gravity = [0.0, 0.0, 0.0]
integrator = "verlet"
domain = {{ lo = [-0.01, -0.01, -0.01], hi = [0.01, 0.01, 0.01] }}

[contact]
model = "{model}"
surface_energy = {GAMMA}

[[material]]
name = "heavy"
youngs_modulus = 1.0e7
poisson_ratio = 0.25
density = 1.0e12
restitution = 1.0
friction = 0.5

[particles]
material = "heavy"
list = [{{ id = 1, position = [0.0, 0.0, {z}], radius = {R} }}]

[[wall]]
name = "floor"
material = "heavy"
plane = {{ point = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0] }}
velocity = [0.0, 0.0, -1.0e-4]

[[phase]]
name = "pull"
duration = 0.02

[output]
interval = 1e-3
"#,
        z = R - 1e-6
    );
    let case = Case::parse(&text, Path::new("pull-off.toml")).unwrap_or_else(|e| panic!("{e}"));
    let mut sim = Simulation::new(case).unwrap_or_else(|e| panic!("{e}"));
    let (mut pull, mut last) = (0.0f64, 0);
    for _ in 0..20_000 {
        sim.step().unwrap();
        // the particles' force on the wall: +z where the sphere pulls it
        let f = sim.walls()[0].force.z;
        if f > pull {
            pull = f;
        }
        if f != 0.0 {
            last = sim.step_count();
        }
    }
    (pull, last)
}

#[test]
fn dmt_pulls_off_a_flat_wall_at_4_pi_gamma_r() {
    let (pull, _) = pull_off("dmt");
    let want = 4.0 * PI * GAMMA * R;
    eprintln!("dmt pull-off {pull:.6e} N, 4 pi gamma R = {want:.6e} N, ratio {:.5}", pull / want);
    assert!((pull / want - 1.0).abs() < 0.01, "pull-off {pull} N against 4 pi gamma R = {want} N");
}

#[test]
fn jkr_pulls_off_a_flat_wall_at_3_pi_gamma_r_beyond_touching() {
    let (pull, last) = pull_off("jkr");
    let want = 3.0 * PI * GAMMA * R;
    eprintln!("jkr pull-off {pull:.6e} N, 3 pi gamma R = {want:.6e} N, ratio {:.5}", pull / want);
    assert!((pull / want - 1.0).abs() < 0.01, "pull-off {pull} N against 3 pi gamma R = {want} N");
    // the contact lasted past touching (1e-6 m at 1e-4 m/s: 10,000 steps) by about
    // the pull-off separation delta_c = a_c^2 / R - 2 sqrt(pi gamma a_c / E*), a_c^3 = 9 pi gamma R^2 / (4 E*)
    // E* of two bodies of one material: E / (2 (1 - nu^2))
    let e = 1.0e7 / (2.0 * (1.0 - 0.25f64 * 0.25));
    let a_c = (9.0 * PI * GAMMA * R * R / (4.0 * e)).cbrt();
    let delta_c = a_c * a_c / R - 2.0 * (PI * GAMMA * a_c / e).sqrt();
    let beyond = (last as f64 - 10_000.0) * 1e-6 * 1e-4;
    eprintln!("jkr let go {beyond:.4e} m beyond touching, |delta_c| = {:.4e} m", -delta_c);
    assert!((beyond / -delta_c - 1.0).abs() < 0.02, "let go {beyond} m beyond touching, against |delta_c| = {} m", -delta_c);
}

/// A case whose `[contact]` section has a pair table appended.
fn with_pairs(pairs: &str) -> Result<talus::sim::Simulation, String> {
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/cases/SC-mixed-laws.toml")).unwrap();
    let i = text.find("\n[[contact.pair]]").unwrap() + 1;
    let j = text.find("\n[[material]]").unwrap() + 1;
    let text = format!("{}{pairs}\n{}", &text[..i], &text[j..]);
    let case = Case::parse(&text, Path::new("pairs.toml")).map_err(|e| e.to_string())?;
    Simulation::new(case).map_err(|e| e.to_string())
}

#[test]
fn a_pair_table_names_its_materials_once_and_its_keys_by_pair() {
    if let Err(e) = with_pairs("[[contact.pair]]\nmaterials = [\"grain\", \"glue\"]\nmodel = \"dmt\"\nsurface_energy = 0.02\n") {
        panic!("{e}");
    }
    for (pairs, want) in [
        ("[[contact.pair]]\nmaterials = [\"grain\", \"rubber\"]\nmodel = \"hertz\"\n", "contact.pair[0].materials = \"rubber\": no material of that name"),
        (
            "[[contact.pair]]\nmaterials = [\"grain\", \"glue\"]\nmodel = \"hertz\"\n[[contact.pair]]\nmaterials = [\"glue\", \"grain\"]\nmodel = \"dmt\"\nsurface_energy = 0.1\n",
            "contact.pair[1].materials",
        ),
        // dmt needs its surface energy: the pair's key is named
        ("[[contact.pair]]\nmaterials = [\"grain\", \"glue\"]\nmodel = \"dmt\"\n", "contact.pair[0].model = \"dmt\""),
        // hertz takes none
        ("[[contact.pair]]\nmaterials = [\"grain\", \"steel\"]\nmodel = \"hertz\"\nsurface_energy = 0.1\n", "contact.pair[0].surface_energy = 0.1"),
        // a convention is the section's, not a pair's
        ("[[contact.pair]]\nmaterials = [\"grain\", \"steel\"]\ntangential = \"total\"\n", "unknown field `tangential`"),
    ] {
        let e = with_pairs(pairs).err().unwrap_or_else(|| panic!("accepted:\n{pairs}"));
        assert!(e.contains(want) && e.contains("pairs.toml"), "{e}\nwanted: {want}");
    }
}
