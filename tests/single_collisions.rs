//! SC set-ups (CASES.md) against theory: restitution, contact duration, peak
//! overlap and force, oblique gross sliding.

mod common;
use common::*;

const SWEEP: [f64; 5] = [0.1, 0.3, 0.5, 0.7, 0.9];

/// The case's one material with restitution `e`.
fn with_e(e: f64) -> impl FnOnce(&mut talus::case::Case) {
    move |c| c.materials[0].restitution = e
}

#[test]
fn sc_wall_and_pair_return_e_in_with_tensile_end_of_contact() {
    for case in ["SC-wall.toml", "SC-wall-hooke.toml", "SC-pair.toml", "SC-pair-hooke.toml"] {
        for e in SWEEP {
            let s = run_case(case, with_e(e));
            let out = num(&s, "restitution");
            assert!((out - e).abs() < 0.005, "{case} e_in {e}: e_out {out}");
        }
    }
}

#[test]
fn clipped_linear_dashpot_returns_the_schwager_poeschel_restitution() {
    // a linear dashpot clipped at zero force: e 0.5 -> 0.550, 0.1 -> 0.253 (DESIGN.md, YADE ViscElMat)
    for (e, expect) in [(0.5, 0.550), (0.1, 0.253)] {
        let s = run_case("SC-wall-hooke.toml", |c| {
            with_e(e)(c);
            c.contact.end_of_contact = Some(talus::contact::EndOfContact::Clip);
        });
        let out = num(&s, "restitution");
        assert!((out - expect).abs() < 0.005, "e_in {e}: e_out {out}, expected {expect}");
    }
}

#[test]
fn elastic_hertz_impacts_match_hertz_theory() {
    let m = mass();
    for (case, r_eff, m_eff, v) in [("SC-wall.toml", R, m, 0.5), ("SC-pair.toml", R / 2.0, m / 2.0, 1.0)] {
        let s = run_case(case, with_e(1.0));
        let (d, t, f) = hertz_theory(y_eff(), r_eff, m_eff, v);
        for (k, th) in [("max_overlap_m", d), ("contact_duration_s", t), ("max_normal_force_n", f)] {
            let got = num(&s, k);
            assert!((got / th - 1.0).abs() < 0.01, "{case} {k}: {got} vs Hertz {th}");
        }
        assert!((num(&s, "restitution") - 1.0).abs() < 1e-3);
    }
}

#[test]
fn hooke_impacts_match_the_linear_closed_form() {
    let m = mass();
    for (case, r_eff, m_eff, v) in [("SC-wall-hooke.toml", R, m, 0.5), ("SC-pair-hooke.toml", R / 2.0, m / 2.0, 1.0)] {
        for e in [1.0, 0.5] {
            let s = run_case(case, with_e(e));
            let kn = talus::contact::hooke::liggghts_kn(y_eff(), r_eff, m_eff, v);
            let g = talus::contact::hooke::damping_for_restitution(m_eff, kn, e);
            let w0 = (kn / m_eff).sqrt();
            let zeta = g / (2.0 * (m_eff * kn).sqrt());
            let w = w0 * (1.0 - zeta * zeta).sqrt();
            // delta(t) = v/w exp(-zeta w0 t) sin(w t): peak where tan(w t) = w / (zeta w0)
            let tp = (w / (zeta * w0)).atan() / w;
            let d = v / w * (-zeta * w0 * tp).exp() * (w * tp).sin();
            // force kn delta + g delta' peaks at t=0 for strong damping, else inside; sample finely
            let fmax = (0..20000)
                .map(|k| {
                    let t = k as f64 * (std::f64::consts::PI / w) / 20000.0;
                    let x = v / w * (-zeta * w0 * t).exp() * (w * t).sin();
                    let xd = v / w * (-zeta * w0 * t).exp() * (w * (w * t).cos() - zeta * w0 * (w * t).sin());
                    kn * x + g * xd
                })
                .fold(0.0, f64::max);
            for (k, th) in [("max_overlap_m", d), ("contact_duration_s", std::f64::consts::PI / w), ("max_normal_force_n", fmax)] {
                let got = num(&s, k);
                assert!((got / th - 1.0).abs() < 0.01, "{case} e {e} {k}: {got} vs closed form {th}");
            }
        }
    }
}

#[test]
fn oblique_gross_sliding_gives_tangential_restitution_one_minus_mu_one_plus_e_over_tan() {
    // sliding throughout needs tan(theta) > 3.5 mu (1 + e) = 2.1 for a solid sphere: theta = 80 degrees
    let (mu, e) = (0.4, 0.5);
    for case in ["SC-oblique.toml", "SC-oblique-hooke.toml"] {
        let th = 80f64.to_radians();
        let s = run_case(case, |c| list(c)[0].velocity = [0.5 * th.sin(), 0.0, -0.5 * th.cos()]);
        let expect = 1.0 - mu * (1.0 + e) / th.tan();
        let got = num(&s, "tangential_restitution");
        assert!((got / expect - 1.0).abs() < 0.01, "{case}: tangential restitution {got} vs {expect}");
        // the spin picked up: omega = 5/2 (v_t,in - v_t,out) / R for a solid sphere
        let spin = num(&s, "spin_rad_s");
        let dv = 0.5 * th.sin() * (1.0 - got);
        assert!((spin / (2.5 * dv / R) - 1.0).abs() < 0.01, "spin {spin}");
    }
}

/// SC-wall (or its hooke variant) with the sphere spinning about y at `spin` rad/s
/// and only a normal velocity (0.5 m/s).
fn spinning_drop(case: &str, spin: f64) -> serde_json::Map<String, serde_json::Value> {
    run_case(case, |c| list(c)[0].spin = [0.0, spin, 0.0])
}

#[test]
fn a_spinning_sphere_dropped_normally_reports_its_tangential_rebound_and_spin_in_the_slip_frame() {
    // The frame: no incoming tangential velocity, so t is the contact point's slip,
    // w x (-R n) = -w R x for w along y: the sphere is pushed along -t (its rebound
    // is negative) and its spin about n x t = -y starts at -w and is braked.
    let (mu, e, vn) = (0.4, 0.5, 0.5);
    let m = mass();
    for case in ["SC-wall.toml", "SC-wall-hooke.toml"] {
        // gross sliding throughout: the slip R w = 2 m/s exceeds the 3.5 mu (1 + e) v_n
        // = 1.05 m/s that the friction impulse can take away (solid sphere), so the
        // tangential impulse is mu times the normal impulse (1 + e) m v_n exactly
        // (talus caps friction on the elastic normal force, whose impulse is all of it)
        let w0 = 1000.0;
        let s = spinning_drop(case, w0);
        assert!((num(&s, "restitution") - e).abs() < 0.005);
        let vt = num(&s, "tangential_rebound_m_s");
        let expect = -mu * (1.0 + e) * vn;
        assert!((vt / expect - 1.0).abs() < 0.01, "{case}: tangential rebound {vt} vs -mu (1 + e) v_n = {expect}");
        // the spin lost: I dw = J_t x arm, the arm R - delta/2 between R - delta_max/2 and R
        // (talus's wall contact point: the middle of the overlap)
        let dw = num(&s, "spin_rad_s") + w0;
        let j = m * vt.abs();
        let (lo, hi) = (j * (R - 0.5 * num(&s, "max_overlap_m")), j * R);
        let i = 0.4 * m * R * R;
        assert!(dw * i > 0.995 * lo && dw * i < 1.005 * hi, "{case}: spin change {dw} outside [{}, {}]", lo / i, hi / i);
        // 50 rad/s: the slip (R w = 0.1 m/s < 1.05 m/s) ends before the contact does; a
        // rigid sphere would then roll off with v_t = 2/7 R w (the rolling limit). The
        // tangential spring lets go before rolling is complete: we measure 0.89 (Hertz)
        // and 0.91 (hooke) of the rolling limit, and hold it to between 0.8 and 1 (a
        // measured band, not a closed form); the spin keeps its sign and is braked
        let w0 = 50.0;
        let s = spinning_drop(case, w0);
        let (vt, w) = (num(&s, "tangential_rebound_m_s"), num(&s, "spin_rad_s"));
        let rolling = 2.0 / 7.0 * R * w0;
        assert!(vt < -0.8 * rolling && vt > -rolling, "{case}: rebound {vt} vs rolling limit {rolling}");
        assert!(w < 0.0 && w > -w0, "{case}: spin {w}");
        assert_eq!(s["tangential_restitution"], serde_json::Value::Null);
    }
}

#[test]
fn normal_impacts_without_spin_still_report_zero_tangential_figures() {
    for case in ["SC-wall.toml", "SC-pair.toml"] {
        let s = run_case(case, |_| {});
        assert_eq!(num(&s, "tangential_rebound_m_s"), 0.0, "{case}");
        assert_eq!(num(&s, "spin_rad_s"), 0.0, "{case}");
        assert_eq!(s["tangential_restitution"], serde_json::Value::Null);
    }
}

/// The last probe row of a run of `case`: (column name, value).
fn last_row(case: &str) -> std::collections::HashMap<String, f64> {
    let dir = tempfile::tempdir().unwrap();
    let opts = talus::run::RunOptions { out: dir.path().to_path_buf(), ..Default::default() };
    talus::run::run(edited(case, |_| {}), &opts).unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(dir.path().join("probes.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let last: Vec<f64> = lines.last().unwrap().split(',').map(|x| x.parse().unwrap_or(f64::NAN)).collect();
    head.into_iter().map(String::from).zip(last).collect()
}

#[test]
fn a_slow_cohesive_impact_sticks_and_a_fast_one_rebounds_slower_than_without_cohesion() {
    // SC-cohesive-*: spheres 1-2 meet at +/-0.02 m/s, 3-4 at +/-0.5 m/s, 5 hits the plate at 0.02 m/s
    for case in ["SC-cohesive-sjkr.toml", "SC-cohesive-sjkr2.toml"] {
        let r = last_row(case);
        let v = |k: &str| r[k];
        // stuck: overlapping at the end, the relative velocity damped out (< 1e-3 of the impact's)
        assert!(v("p2_x_m") - v("p1_x_m") < 0.004, "{case}: the slow pair separated");
        assert!((v("p2_vx_m_s") - v("p1_vx_m_s")).abs() < 4e-5, "{case}: slow pair still moving");
        assert!(v("p5_z_m") - 0.002 < -0.01 && v("p5_vz_m_s").abs() < 1e-4, "{case}: the sphere left the plate");
        // rebound: apart, slower than the restitution 0.5 of the cohesionless law gives
        let e = (v("p4_vx_m_s") - v("p3_vx_m_s")) / 1.0;
        assert!(v("p4_x_m") - v("p3_x_m") > 0.004 && e > 0.2 && e < 0.48, "{case}: fast pair's restitution {e}");
        assert_eq!(v("contacts"), 2.0, "{case}");
    }
}
