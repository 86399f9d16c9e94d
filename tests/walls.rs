//! Wall behaviour in whole runs: a wall moving with a prescribed velocity, a wall
//! removed at a time, and a sphere on the shared edge of two coplanar STL triangles.

mod common;
use common::*;
use talus::case::WallSection;

#[test]
fn moving_wall_launches_a_resting_sphere_at_twice_its_speed() {
    // elastic impact with an infinitely massive wall moving at 0.5 m/s: the sphere leaves at 1.0 m/s
    let mut sim = sim("SC-wall.toml", |c| {
        c.materials[0].restitution = 1.0;
        list(c)[0].velocity = [0.0; 3];
        wall(c, "plate").velocity = [0.0, 0.0, 0.5];
    });
    while sim.time() < 0.004 {
        sim.step().unwrap();
    }
    let vz = sim.particles().vel[0].z;
    assert!((vz - 1.0).abs() < 1e-3, "sphere speed after the moving wall hit it: {vz}");
}

#[test]
fn wall_removed_at_a_time_no_longer_acts() {
    // the plate goes at 0.1 ms, before the sphere reaches it: no collision
    let s = run_case("SC-wall.toml", |c| {
        wall(c, "plate").remove_at = Some(1e-4);
        c.simulation.domain.lo = [-0.01, -0.01, -0.01];
    });
    assert_eq!(num(&s, "restitution"), -1.0, "the sphere must pass unhindered");
    assert_eq!(num(&s, "max_overlap_m"), 0.0);
}

#[test]
fn sphere_dropped_on_the_shared_edge_of_an_stl_square_bounces_once_with_one_contact() {
    let d = tempfile::tempdir().unwrap();
    // a 20 mm square plate in z = 0 made of two triangles sharing the diagonal through the origin
    let mut v = Vec::new();
    let mut t = Vec::new();
    use talus::dim::Vec3;
    talus::walls::mesh::push_quad(&mut v, &mut t, [
        Vec3::new(-0.01, -0.01, 0.0),
        Vec3::new(0.01, -0.01, 0.0),
        Vec3::new(0.01, 0.01, 0.0),
        Vec3::new(-0.01, 0.01, 0.0),
    ]);
    let m = talus::walls::Mesh::new(v, t).unwrap();
    let stl = d.path().join("square.stl");
    m.write_stl(&stl).unwrap();
    // the sphere falls on the diagonal (x = y = 0): one contact, so Hertz's peak overlap
    let mut mesh_sim = sim("SC-wall.toml", |c| {
        c.materials[0].restitution = 1.0;
        wall(c, "plate").shape = talus::case::WallShape::Stl(stl.clone());
        c.analysis = None;
    });
    let mut max_contacts = 0;
    let mut max_overlap: f64 = 0.0;
    while mesh_sim.time() < 0.004 {
        mesh_sim.step().unwrap();
        max_contacts = max_contacts.max(mesh_sim.local_contacts());
        max_overlap = max_overlap.max(0.002 - mesh_sim.particles().pos[0].z);
    }
    assert_eq!(max_contacts, 1);
    let (d_hertz, _, _) = hertz_theory(y_eff(), R, mass(), 0.5);
    assert!((max_overlap / d_hertz - 1.0).abs() < 0.01, "overlap {max_overlap} vs {d_hertz}");
    assert!((mesh_sim.particles().vel[0].z - 0.5).abs() < 1e-3);
}

#[test]
fn a_wall_moving_in_from_afar_still_finds_the_sphere() {
    // the plate starts 5 mm below the sphere (far outside the skin) and sweeps up at 0.5 m/s
    let mut sim = sim("SC-wall.toml", |c| {
        c.materials[0].restitution = 1.0;
        list(c)[0].velocity = [0.0; 3];
        *wall(c, "plate") = WallSection::plane("plate", "seed-soft", [0.0, 0.0, -0.005], [0.0, 0.0, 1.0]).moving([0.0, 0.0, 0.5]);
        c.simulation.domain.lo = [-0.01, -0.01, -0.01];
        phase(c, "collide").duration = 0.016;
    });
    while sim.time() < 0.016 {
        sim.step().unwrap();
    }
    let vz = sim.particles().vel[0].z;
    assert!((vz - 1.0).abs() < 1e-3, "sphere speed after the moving wall hit it: {vz}");
}

#[test]
fn ascii_and_binary_stl_give_the_same_mesh() {
    let d = tempfile::tempdir().unwrap();
    let (hopper, _) = talus::generate::hopper_meshes();
    let bin = d.path().join("hopper_bin.stl");
    hopper.write_stl(&bin).unwrap();
    let mut ascii = String::from("solid hopper\n");
    for t in &hopper.triangles {
        ascii.push_str("  facet normal 0 0 0\n    outer loop\n");
        for &v in t {
            let p = hopper.vertices[v as usize];
            ascii.push_str(&format!("      vertex {:e} {:e} {:e}\n", p.x as f32, p.y as f32, p.z as f32));
        }
        ascii.push_str("    endloop\n  endfacet\n");
    }
    ascii.push_str("endsolid hopper\n");
    let asc = d.path().join("hopper_ascii.stl");
    std::fs::write(&asc, ascii).unwrap();
    let a = talus::walls::Mesh::from_stl(&asc).unwrap();
    let b = talus::walls::Mesh::from_stl(&bin).unwrap();
    assert_eq!(a.triangles.len(), 16);
    assert_eq!(a.vertices.len(), b.vertices.len());
    // same shape: a sphere in the converging section touches both the same way
    let c = talus::dim::Vec3::new(0.0, 0.0, 0.01);
    let ha: Vec<_> = (0..16).filter_map(|t| a.contact(t, &c, 0.03)).map(|h| h.overlap).collect();
    let hb: Vec<_> = (0..16).filter_map(|t| b.contact(t, &c, 0.03)).map(|h| h.overlap).collect();
    assert_eq!(ha.len(), 4);
    assert_eq!(ha, hb);
}
