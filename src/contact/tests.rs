//! Per-law analytic tests and proptest invariants.

use super::hertz::{Hertz, HertzDamping};
use super::hooke::{damping_for_restitution, liggghts_kn, Hooke, HookeExplicit};
use super::*;
use crate::material::{mix, Material, Mixing};
use super::geometry::Lever;
use approx::assert_relative_eq;
use proptest::prelude::*;

fn soft(e: f64, mu: f64) -> Material {
    Material {
        name: "m".into(),
        youngs_modulus: 1e6,
        poisson_ratio: 0.3,
        density: 2500.0,
        restitution: e,
        friction: mu,
        rolling_friction: 0.0,
    }
}

fn pm(e: f64, mu: f64) -> PairMaterial {
    let m = soft(e, mu);
    mix(&m, &m, Mixing::Liggghts)
}

const TANG: TangentialOptions =
    TangentialOptions { history: TangentialHistory::Total, cap: FrictionCap::Total, kinematics: ShearKinematics::ContactPoint };

/// Two spheres with arms `arm_i`, `arm_j` along n (a sphere on a wall when `arm_j` is 0).
fn along(n: Vec3, overlap: f64, arm_i: f64, arm_j: f64) -> ContactGeom {
    if arm_j == 0.0 {
        ContactGeom::sphere_wall(n, overlap, arm_i, arm_i)
    } else {
        ContactGeom::spheres(n, overlap, [arm_i, arm_j], [arm_i, arm_j])
    }
}

fn geom(overlap: f64) -> ContactGeom {
    along(Vec3::z(), overlap, 0.002 - overlap / 2.0, 0.002 - overlap / 2.0)
}

fn opts(end: EndOfContact, tang: TangentialOptions) -> ContactOptions {
    ContactOptions { damping: HertzDamping::Liggghts, end, tang, wall_arm_overlap: 0.5, mixing: Mixing::Liggghts, rolling: None, rolling_wall_spin_scaled: false }
}

/// Body i moving at v relative to a body j at rest, neither spinning.
fn moving(v: Vec3) -> Motion {
    Motion { v_i: v, w_i: Vec3::zeros(), v_j: Vec3::zeros(), w_j: Vec3::zeros() }
}

/// One evaluation with the law's per-pair constants made on the spot.
#[allow(clippy::too_many_arguments)]
fn eval<L: ContactLaw>(law: L, end: EndOfContact, tang: TangentialOptions, p: &PairMaterial, pi: PairInertia, g: &ContactGeom, v: Vec3, h: &mut Vec3, dt: f64) -> ContactForce {
    law.contact(&opts(end, tang), p, pi, &law.pair(p, pi), g, &moving(v), h, &mut Vec3::zeros(), dt)
}

#[test]
fn hertz_elastic_force_is_four_thirds_y_sqrt_r_delta_three_halves() {
    let p = pm(1.0, 0.0);
    let pi = PairInertia::particles(0.002, 0.003, 1e-4, 2e-4);
    for d in [1e-6, 1e-5, 1e-4] {
        let mut h = Vec3::zeros();
        let c = eval(Hertz { damping: HertzDamping::Liggghts }, EndOfContact::Tensile, TANG, &p, pi, &geom(d), Vec3::zeros(), &mut h, 1e-6);
        let expect = 4.0 / 3.0 * p.y_eff * pi.r_eff.sqrt() * d.powf(1.5);
        assert_relative_eq!(c.force.z, expect, max_relative = 1e-12);
        assert_relative_eq!(c.force.x, 0.0);
    }
}

#[test]
fn hooke_explicit_force_is_kn_delta_minus_gamma_vn() {
    let h = HookeExplicit { kn: 100.0, kt: 80.0, gamma_n: 0.3, gamma_t: 0.2 };
    let p = pm(0.5, 0.4);
    let pi = PairInertia::wall(0.002, 1e-4);
    let mut hist = Vec3::zeros();
    let c = eval(Hooke::Explicit(h), EndOfContact::Tensile, TANG, &p, pi, &geom(1e-4), Vec3::new(0.0, 0.0, -0.2), &mut hist, 1e-6);
    assert_relative_eq!(c.force.z, 100.0 * 1e-4 + 0.3 * 0.2, max_relative = 1e-14);
    // separating fast: the force goes tensile, or is clipped at zero
    let c = eval(Hooke::Explicit(h), EndOfContact::Tensile, TANG, &p, pi, &geom(1e-5), Vec3::new(0.0, 0.0, 1.0), &mut hist, 1e-6);
    assert!(c.normal < 0.0);
    let c = eval(Hooke::Explicit(h), EndOfContact::Clip, TANG, &p, pi, &geom(1e-5), Vec3::new(0.0, 0.0, 1.0), &mut hist, 1e-6);
    assert_eq!(c.normal, 0.0);
}

#[test]
fn liggghts_hooke_stiffness_matches_hertz_peak_overlap_at_v() {
    // the linear spring k_n has Hertz's peak overlap at the characteristic velocity
    let p = pm(0.5, 0.4);
    let (r, m, v) = (0.001, 8.4e-5 / 2.0, 0.7);
    let kn = liggghts_kn(p.y_eff, r, m, v);
    let hooke_peak = v * (m / kn).sqrt();
    let hertz_peak = (15.0 * m * v * v / (16.0 * p.y_eff * r.sqrt())).powf(0.4);
    assert_relative_eq!(hooke_peak, hertz_peak, max_relative = 1e-12);
    // the damping gives restitution e for the tensile linear dashpot
    for e in [0.1, 0.3, 0.5, 0.7, 0.9] {
        let g = damping_for_restitution(m, kn, e);
        let zeta = g / (2.0 * (m * kn).sqrt());
        let e_lin = (-zeta * std::f64::consts::PI / (1.0 - zeta * zeta).sqrt()).exp();
        assert_relative_eq!(e_lin, e, max_relative = 1e-12);
    }
}

#[test]
fn zero_overlap_zero_velocity_gives_zero_force() {
    let p = pm(0.5, 0.4);
    let pi = PairInertia::particles(0.002, 0.002, 1e-4, 1e-4);
    for law in [Hertz { damping: HertzDamping::Liggghts }, Hertz { damping: HertzDamping::Yade }] {
        let mut h = Vec3::zeros();
        let c = eval(law, EndOfContact::Tensile, TANG, &p, pi, &geom(0.0), Vec3::zeros(), &mut h, 1e-6);
        assert_eq!(c.force, Vec3::zeros());
    }
    let mut h = Vec3::zeros();
    let c = eval(Hooke::Derived { characteristic_velocity: 0.5 }, EndOfContact::Tensile, TANG, &p, pi, &geom(0.0), Vec3::zeros(), &mut h, 1e-6);
    assert_eq!(c.force, Vec3::zeros());
}

#[test]
fn conventions_fill_every_option_not_given() {
    use crate::case::{ContactSection, ModelName};
    let section = |convention, model| ContactSection {
        model,
        convention,
        damping: None,
        end_of_contact: None,
        tangential: None,
        friction_cap: None,
        shear_kinematics: None,
        wall_contact_point: None,
        characteristic_velocity: None,
        stiffness: None,
        rolling: None,
        cohesion: None,
        surface_energy: None,
        pairs: Vec::new(),
    };
    // LAMMPS: tsuji damping, rescaled history, full radii as spin arms, the
    // cap |F_el + 2 F_pulloff| (the total force for a law that does not pull),
    // the wall's torque arm the radius; dmt and jkr pull in every convention
    let lm = conventions::resolve(&section(Convention::Lammps, ModelName::Hertz));
    assert_eq!((lm.damping, lm.end, lm.tang.history), (HertzDamping::Tsuji, EndOfContact::Tensile, TangentialHistory::Rescaled));
    assert_eq!((lm.tang.cap, lm.tang.kinematics, lm.wall_arm_overlap, lm.mixing), (FrictionCap::Pulloff, ShearKinematics::Radii, 0.0, Mixing::Liggghts));
    let yd = conventions::resolve(&section(Convention::Yade, ModelName::Dmt));
    assert_eq!((yd.end, yd.tang.cap), (EndOfContact::Tensile, FrictionCap::Pulloff));
    let t = conventions::resolve(&section(Convention::Talus, ModelName::Hertz));
    assert_eq!((t.damping, t.end, t.tang.history), (HertzDamping::Liggghts, EndOfContact::Tensile, TangentialHistory::Total));
    assert_eq!((t.tang.cap, t.tang.kinematics, t.wall_arm_overlap, t.mixing), (FrictionCap::Elastic, ShearKinematics::ContactPoint, 0.5, Mixing::Liggghts));
    let l = conventions::resolve(&section(Convention::Liggghts, ModelName::Hertz));
    assert_eq!(l, ContactOptions { tang: TangentialOptions { cap: FrictionCap::Total, ..t.tang }, rolling_wall_spin_scaled: true, ..t });
    let y = conventions::resolve(&section(Convention::Yade, ModelName::Hertz));
    assert_eq!((y.damping, y.end, y.tang.history), (HertzDamping::Yade, EndOfContact::Clip, TangentialHistory::Incremental));
    assert_eq!((y.tang.cap, y.tang.kinematics, y.wall_arm_overlap, y.mixing), (FrictionCap::Total, ShearKinematics::FullRadii, 1.0, Mixing::Yade));
    // YADE's ViscEl (hooke) drives the shear spring with the contact-point velocity
    let yh = conventions::resolve(&section(Convention::Yade, ModelName::Hooke));
    assert_eq!(yh.tang.kinematics, ShearKinematics::ContactPoint);
    // a key given wins over the convention
    let given = ContactSection { friction_cap: Some(FrictionCap::Elastic), ..section(Convention::Yade, ModelName::Hertz) };
    assert_eq!(conventions::resolve(&given).tang.cap, FrictionCap::Elastic);
}

#[test]
fn hooke_derives_its_coefficients_once_per_pair_to_the_bit() {
    let p = pm(0.5, 0.4);
    let pi = PairInertia::particles(0.002, 0.0015, 1e-4, 3e-5);
    let law = Hooke::Derived { characteristic_velocity: 0.5 };
    let h = law.pair(&p, pi);
    let kn = liggghts_kn(p.y_eff, pi.r_eff, pi.m_eff, 0.5);
    assert_eq!(h, HookeExplicit { kn, kt: kn, gamma_n: damping_for_restitution(pi.m_eff, kn, 0.5), gamma_t: h.gamma_n });
    let c = law.normal(&p, pi, &h, 1e-5);
    assert_eq!(c.f_elastic, kn * 1e-5);
}

#[test]
fn two_spheres_touch_in_the_middle_of_their_overlap() {
    let (xi, xj) = (Vec3::new(0.0, 0.0, 0.0035), Vec3::zeros());
    let g = geometry::sphere_sphere(xi, 0.002, xj, 0.0025).unwrap();
    assert_eq!((g.n, g.r_eff), (Vec3::z(), None));
    assert_relative_eq!(g.overlap, 0.001, max_relative = 1e-12);
    // arms r - delta/2: the point is 1.5 mm from i's centre, 2 mm from j's
    assert_relative_eq!(g.point(xi).z, 0.002, max_relative = 1e-12);
    assert_relative_eq!(g.branch_j().unwrap().z, 0.002, max_relative = 1e-12);
    assert_eq!(geometry::sphere_sphere(xi, 0.001, xj, 0.0025), None);
}

proptest! {
    /// The scalar arms along n (spheres) and the branch vectors (any shape) are
    /// the same kinematics: w x r and r x F with r = -arm_i n and arm_j n.
    #[test]
    fn along_normal_arms_are_branch_vectors(a in 0.0..std::f64::consts::PI, b in 0.0..std::f64::consts::TAU, ai in 1e-4..3e-3f64, aj in 1e-4..3e-3f64,
                                            w in prop::array::uniform6(-50.0..50.0f64), f in prop::array::uniform3(-1.0..1.0f64)) {
        let n = unit(a, b);
        let g = along(n, 1e-5, ai, aj);
        let gb = ContactGeom { lever: Lever::Branch { point: Vec3::zeros(), branch_i: g.branch_i(), branch_j: g.branch_j() }, ..g };
        prop_assert_eq!(g.branch_i(), -n * ai);
        prop_assert_eq!(g.branch_j(), Some(n * aj));
        let m = Motion { v_i: Vec3::new(0.1, -0.2, 0.3), w_i: Vec3::new(w[0], w[1], w[2]), v_j: Vec3::zeros(), w_j: Vec3::new(w[3], w[4], w[5]) };
        let ((v, _), (vb, _)) = (g.velocities(ShearKinematics::ContactPoint, &m), gb.velocities(ShearKinematics::ContactPoint, &m));
        prop_assert!((v - vb).norm() <= 1e-14 * (1.0 + vb.norm()));
        let f = Vec3::new(f[0], f[1], f[2]);
        let ((ti, tj), (tbi, tbj)) = (g.torques(f), gb.torques(f));
        prop_assert!((ti - tbi).norm() + (tj - tbj).norm() <= 1e-15 * (ai + aj));
    }

    /// A wall has no centre: its torque is about the contact point, zero for a
    /// force alone, and its velocity is the same everywhere.
    #[test]
    fn a_wall_takes_no_torque_about_the_contact_point(a in 0.0..std::f64::consts::PI, b in 0.0..std::f64::consts::TAU, d in 1e-7..2e-4f64,
                                                      f in prop::array::uniform3(-1.0..1.0f64)) {
        let n = unit(a, b);
        let hit = crate::walls::WallHit { n, overlap: d, point: n * 0.001, feature: 0 };
        let g = hit.sphere_geometry(0.003, 0.5);
        prop_assert_eq!(g.branch_j(), None);
        // the force acts at the middle of the overlap
        let x = n * (0.003 - d);
        prop_assert!((g.point(x) + n * (0.5 * d)).norm() <= 1e-15);
        prop_assert!(g.torques(Vec3::new(f[0], f[1], f[2])).1.norm() == 0.0);
        let gb = ContactGeom { lever: Lever::Branch { point: g.point(x), branch_i: g.branch_i(), branch_j: None }, ..g };
        prop_assert!(gb.torques(Vec3::new(f[0], f[1], f[2])).1 == Vec3::zeros());
    }
}

fn any_law() -> impl Strategy<Value = (bool, bool, bool)> {
    (any::<bool>(), any::<bool>(), any::<bool>())
}

fn eval_any(sel: (bool, bool, bool), p: &PairMaterial, pi: PairInertia, g: &ContactGeom, v: Vec3, h: &mut Vec3) -> ContactForce {
    let end = if sel.1 { EndOfContact::Clip } else { EndOfContact::Tensile };
    let tang = TangentialOptions {
        history: if sel.2 { TangentialHistory::Incremental } else { TangentialHistory::Total },
        cap: FrictionCap::Total,
        kinematics: ShearKinematics::ContactPoint,
    };
    if sel.0 {
        eval(Hertz { damping: HertzDamping::Liggghts }, end, tang, p, pi, g, v, h, 1e-5)
    } else {
        eval(Hooke::Derived { characteristic_velocity: 0.5 }, end, tang, p, pi, g, v, h, 1e-5)
    }
}

fn unit(a: f64, b: f64) -> Vec3 {
    let (s, c) = a.sin_cos();
    Vec3::new(s * b.cos(), s * b.sin(), c)
}

proptest! {
    #[test]
    fn newtons_third_law(sel in any_law(), a in 0.0..std::f64::consts::PI, b in 0.0..std::f64::consts::TAU, d in 1e-7..2e-4f64,
                         vx in -1.0..1.0f64, vy in -1.0..1.0f64, vz in -1.0..1.0f64, e in 0.1..1.0f64, mu in 0.0..1.0f64) {
        let p = pm(e, mu);
        let pi = PairInertia::particles(0.002, 0.0025, 1e-4, 1.5e-4);
        let n = unit(a, b);
        let v = Vec3::new(vx, vy, vz);
        let g = along(n, d, 0.002, 0.0025);
        let gs = along(-n, d, 0.0025, 0.002);
        let (mut h1, mut h2) = (Vec3::zeros(), Vec3::zeros());
        for _ in 0..3 {
            let f1 = eval_any(sel, &p, pi, &g, v, &mut h1);
            let f2 = eval_any(sel, &p, pi, &gs, -v, &mut h2);
            prop_assert!((f1.force + f2.force).norm() <= 1e-12 * f1.force.norm().max(1e-30));
        }
    }

    #[test]
    fn frame_indifference(sel in any_law(), a in 0.0..std::f64::consts::PI, b in 0.0..std::f64::consts::TAU, d in 1e-7..2e-4f64,
                          vx in -1.0..1.0f64, vy in -1.0..1.0f64, vz in -1.0..1.0f64,
                          ax in -1.0..1.0f64, ay in -1.0..1.0f64, az in -1.0..1.0f64) {
        let p = pm(0.5, 0.4);
        let pi = PairInertia::wall(0.002, 1e-4);
        let n = unit(a, b);
        let rot = nalgebra::Rotation3::new(Vec3::new(ax, ay, az) * 2.0);
        let v = Vec3::new(vx, vy, vz);
        let g = along(n, d, 0.002, 0.0);
        let gr = along(rot * n, d, 0.002, 0.0);
        // the rounding is relative to the force's terms, not to their sum: the
        // elastic and viscous normal forces nearly cancel at the end of a contact
        // (a tensile normal force a millionth of either), so the scale is the
        // elastic force at this overlap (the force at rest) where it is larger
        let elastic = eval_any(sel, &p, pi, &g, Vec3::zeros(), &mut Vec3::zeros()).force.norm();
        let (mut h1, mut h2) = (Vec3::zeros(), Vec3::zeros());
        for _ in 0..3 {
            let f1 = eval_any(sel, &p, pi, &g, v, &mut h1);
            let f2 = eval_any(sel, &p, pi, &gr, rot * v, &mut h2);
            prop_assert!((rot * f1.force - f2.force).norm() <= 1e-10 * f1.force.norm().max(elastic).max(1e-30));
        }
    }

    #[test]
    fn coulomb_cap_holds_while_sliding(sel in any_law(), d in 1e-7..2e-4f64, vt in 0.5..5.0f64, mu in 0.01..1.0f64) {
        // 2000 steps of 1e-5 s at vt >= 0.5 m/s: a centimetre of slip, far past sticking
        let p = pm(0.5, mu);
        let pi = PairInertia::wall(0.002, 1e-4);
        let g = along(Vec3::z(), d, 0.002, 0.0);
        let mut h = Vec3::zeros();
        let mut f = eval_any(sel, &p, pi, &g, Vec3::new(vt, 0.0, 0.0), &mut h);
        for _ in 0..2000 {
            f = eval_any(sel, &p, pi, &g, Vec3::new(vt, 0.0, 0.0), &mut h);
        }
        let ft = Vec3::new(f.force.x, f.force.y, 0.0).norm();
        let cap = mu * f.normal.abs();
        prop_assert!((ft - cap).abs() <= 1e-9 * cap, "ft {} cap {}", ft, cap);
        prop_assert!(f.force.x < 0.0, "friction opposes the slip");
    }

    #[test]
    fn explicit_hooke_held_by_the_law_gives_the_per_pair_form_bit_for_bit_without_r_or_m(
        d in 1e-7..2e-4f64, vx in -2.0..2.0f64, vy in -2.0..2.0f64, vz in -0.3..0.3f64, mu in 0.0..1.0f64,
        clip in any::<bool>(), incremental in any::<bool>(), wall in any::<bool>()) {
        // the law with its one set of coefficients (the sweep hands it NaN for
        // R* and m*, which it must never read) against Hooke::Explicit with the
        // pair's real R*, m*: every bit of the force, torques and history alike,
        // sticking and sliding, over a run of steps
        let h = HookeExplicit { kn: 200.0, kt: 170.0, gamma_n: 0.016, gamma_t: 0.012 };
        let p = pm(0.5, mu);
        let end = if clip { EndOfContact::Clip } else { EndOfContact::Tensile };
        let tang = TangentialOptions { history: if incremental { TangentialHistory::Incremental } else { TangentialHistory::Total }, ..TANG };
        let (g, pi) = if wall {
            (along(Vec3::z(), d, 0.002 - d / 2.0, 0.0), PairInertia::wall(0.002, 1e-4))
        } else {
            (along(Vec3::z(), d, 0.002 - d / 2.0, 0.0025 - d / 2.0), PairInertia::particles(0.002, 0.0025, 1e-4, 1.5e-4))
        };
        let (mut h1, mut h2) = (Vec3::zeros(), Vec3::zeros());
        for k in 0..50 {
            let v = Vec3::new(vx * (k as f64 * 0.1).cos(), vy, vz);
            let a = eval(h, end, tang, &p, PairInertia::UNUSED, &g, v, &mut h1, 1e-5);
            let b = eval(Hooke::Explicit(h), end, tang, &p, pi, &g, v, &mut h2, 1e-5);
            let bits = |c: &ContactForce| [c.force, c.torque_i, c.torque_j].map(|x| x.map(f64::to_bits));
            prop_assert_eq!(bits(&a), bits(&b));
            prop_assert_eq!(a.normal.to_bits(), b.normal.to_bits());
            prop_assert_eq!(h1.map(f64::to_bits), h2.map(f64::to_bits));
        }
    }

    #[test]
    fn incremental_elastic_shear_never_exceeds_cap(d in 1e-7..2e-4f64, vt in -2.0..2.0f64, vn in -0.3..0.3f64, mu in 0.0..1.0f64) {
        let p = pm(0.5, mu);
        let pi = PairInertia::wall(0.002, 1e-4);
        let g = along(Vec3::z(), d, 0.002, 0.0);
        let mut h = Vec3::zeros();
        for k in 0..100 {
            let v = Vec3::new(vt * (k as f64 * 0.1).cos(), vt * (k as f64 * 0.07).sin(), vn);
            let f = eval_any((true, false, true), &p, pi, &g, v, &mut h);
            prop_assert!(h.norm() <= mu * f.normal.abs() * (1.0 + 1e-12) + 1e-300);
        }
    }
}

#[test]
fn epsd2_rolling_spring_winds_up_by_kt_r2_w_dt_caps_at_mu_r_f_r_and_ignores_twist() {
    let law = Hooke::Explicit(HookeExplicit { kn: 1000.0, kt: 800.0, gamma_n: 0.0, gamma_t: 0.0 });
    let mut p = pm(1.0, 0.5);
    p.rolling_friction = 0.1;
    let (r, dt, d) = (0.002, 1e-6, 1e-5);
    let o = ContactOptions { rolling: Some(RollingModel::Epsd2), ..opts(EndOfContact::Tensile, TANG) };
    // two spheres of radius r (R* = r/2), i rolling about x and twisting about n = z
    let pi = PairInertia::particles(r, r, 1e-4, 1e-4);
    let g = along(Vec3::z(), d, r - d / 2.0, r - d / 2.0);
    let m = Motion { v_i: Vec3::zeros(), w_i: Vec3::new(3.0, 0.0, 50.0), v_j: Vec3::zeros(), w_j: Vec3::zeros() };
    let (mut h, mut roll) = (Vec3::zeros(), Vec3::zeros());
    let kr = 800.0 * (r / 2.0) * (r / 2.0);
    let c = law.contact(&o, &p, pi, &law.pair(&p, pi), &g, &m, &mut h, &mut roll, dt);
    assert_relative_eq!(roll.x, kr * 3.0 * dt, max_relative = 1e-12);
    assert_eq!((roll.y, roll.z), (0.0, 0.0), "the twist about n winds no rolling spring");
    // the spring's torque is taken from i and given to j, beside r x F (the same without the law)
    let off = ContactOptions { rolling: None, ..o };
    let c0 = law.contact(&off, &p, pi, &law.pair(&p, pi), &g, &m, &mut Vec3::zeros(), &mut Vec3::zeros(), dt);
    assert_relative_eq!(c.torque_i.x - c0.torque_i.x, -roll.x, max_relative = 1e-9);
    assert_relative_eq!(c.torque_j.x - c0.torque_j.x, roll.x, max_relative = 1e-9);
    // wound on, it stops at mu_r F_n R* = 0.1 * kn d * r/2
    let cap = 0.1 * 1000.0 * d * (r / 2.0);
    for _ in 0..100_000 {
        law.contact(&o, &p, pi, &law.pair(&p, pi), &g, &m, &mut h, &mut roll, dt);
    }
    assert_relative_eq!(roll.norm(), cap, max_relative = 1e-12);
    // spun back, it unloads elastically at once: by kr w dt from the cap
    let back = Motion { w_i: Vec3::new(-3.0, 0.0, 0.0), ..m };
    law.contact(&o, &p, pi, &law.pair(&p, pi), &g, &back, &mut h, &mut roll, dt);
    assert_relative_eq!(roll.x, cap - kr * 3.0 * dt, max_relative = 1e-12);
    // against a wall the arm is the particle's radius; LIGGGHTS's convention
    // drives the spring by w (r - d/2) / (r - d)
    for (scaled, factor) in [(false, 1.0), (true, (r - d / 2.0) / (r - d))] {
        let o = ContactOptions { rolling_wall_spin_scaled: scaled, ..o };
        let (pw, gw) = (PairInertia::wall(r, 1e-4), ContactGeom::sphere_wall(Vec3::z(), d, r - d / 2.0, r));
        let mut roll = Vec3::zeros();
        law.contact(&o, &p, pw, &law.pair(&p, pw), &gw, &m, &mut Vec3::zeros(), &mut roll, dt);
        assert_relative_eq!(roll.x, 800.0 * r * r * 3.0 * factor * dt, max_relative = 1e-12);
    }
}

#[test]
fn hooke_takes_exactly_one_of_stiffness_and_characteristic_velocity_whichever_law_type_runs_it() {
    // explicit stiffness dispatches to the law that holds its coefficients,
    // a characteristic velocity to the per-pair one; both, or a bad value,
    // are refused with the same key and message either way
    let mut c = crate::case::ContactSection::new(crate::case::ModelName::Hooke);
    let h = HookeExplicit { kn: 200.0, kt: 200.0, gamma_n: 0.016, gamma_t: 0.016 };
    c.stiffness = Some(h);
    assert_eq!(check_law(&c), Ok(()));
    c.characteristic_velocity = Some(0.5);
    let e = check_law(&c).unwrap_err();
    assert_eq!((e.key.as_str(), e.value.as_str()), ("contact.model", "\"hooke\""));
    assert!(e.why.starts_with("give exactly one of contact.stiffness"), "{}", e.why);
    c.stiffness = None;
    assert_eq!(check_law(&c), Ok(()));
    c.characteristic_velocity = None;
    c.stiffness = Some(HookeExplicit { kn: -1.0, ..h });
    let e = check_law(&c).unwrap_err();
    assert_eq!((e.key.as_str(), e.value.as_str()), ("contact.stiffness.kn", "-1"));
}

#[test]
fn cohesion_pulls_beside_the_law_and_leaves_the_friction_cap_alone() {
    use super::cohesion::{Cohesion, CohesionModel};
    let p = pm(0.5, 0.4);
    let pi = PairInertia::particles(0.002, 0.002, 1e-4, 1e-4);
    let d = 1e-4;
    for model in [CohesionModel::Sjkr, CohesionModel::Sjkr2] {
        let coh = Cohesion { model, energy_density: 3e4 };
        let o = opts(EndOfContact::Tensile, TANG);
        let law = Hertz { damping: HertzDamping::Liggghts };
        let cohesive = super::cohesion::Cohesive { law, cohesion: coh };
        let run = |cohesive_law: bool, g: &ContactGeom, v: Vec3| {
            // (a step long enough that the shear spring passes the Coulomb cap at once)
            let (h, r) = (&mut Vec3::zeros(), &mut Vec3::zeros());
            if cohesive_law {
                cohesive.contact(&o, &p, pi, &(), g, &moving(v), h, r, 1.0)
            } else {
                law.contact(&o, &p, pi, &(), g, &moving(v), h, r, 1.0)
            }
        };
        for g in [geom(d), along(Vec3::z(), d, 0.002 - d / 2.0, 0.0)] {
            let Lever::AlongNormal { radius_i, radius_j, .. } = g.lever else { unreachable!("spheres") };
            // at rest: the law's elastic force plus -k A along the normal
            let (a, b) = (run(false, &g, Vec3::zeros()), run(true, &g, Vec3::zeros()));
            let f_coh = coh.force(radius_i, radius_j, d);
            assert!(f_coh < 0.0);
            assert_relative_eq!(b.force.z, a.force.z + f_coh, max_relative = 1e-14);
            assert_relative_eq!(b.normal, a.normal + f_coh, max_relative = 1e-14);
            // sliding: the tangential force is capped by mu times the law's normal force, cohesion aside
            let (a, b) = (run(false, &g, Vec3::x()), run(true, &g, Vec3::x()));
            assert_eq!(a.force.x, b.force.x);
            assert_relative_eq!(b.force.x.abs(), 0.4 * a.normal.abs(), max_relative = 1e-12);
        }
        // no overlap, no cohesion (it does not reach beyond contact)
        assert_eq!(coh.force(0.002, 0.002, 0.0), 0.0);
    }
}
