//! The drag paper (CASES.md D2) with disc granules: `talus drag` over 5 seeded beds.

use std::path::Path;
use talus::drag::{run, DragCase};

fn drag(id: &str) -> (f64, f64) {
    let dc = DragCase::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/drag").join(format!("{id}.toml"))).unwrap();
    let d = tempfile::tempdir().unwrap();
    let s = run(&dc, d.path()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s["beds"], 5);
    assert!(d.path().join("drag_vs_displacement.csv").exists());
    (s["mean_drag_n"].as_f64().unwrap(), s["std_drag_n"].as_f64().unwrap())
}

#[test]
fn ten_times_the_density_changes_the_disc_drag_by_less_than_25_percent() {
    // paper, section 3.4: at most 21.8% over its cases; the bed's compaction
    // stress, not gravity or the granules' momentum, sets the drag
    let (light, s_light) = drag("c11");
    let (heavy, _) = drag("c12");
    assert!(light > 0.0 && s_light < 0.25 * light, "c11 {light} +- {s_light}");
    assert!((heavy / light - 1.0).abs() < 0.25, "c11 {light} N, c12 {heavy} N");
}

#[test]
fn dumbbells_drag_more_than_discs_the_size_of_their_lobes() {
    // paper, section 3.3: d1 (dumbbells of volume diameter 1092 um, lobes of 772 um)
    // shows significantly higher drag than c2 (discs of 772 um)
    let (d1, sd) = drag("d1");
    let (c2, sc) = drag("c2");
    assert!(d1 - sd > c2 + sc, "d1 {d1} +- {sd} N, c2 {c2} +- {sc} N");
}

#[test]
fn shapes_not_yet_implemented_are_refused_plainly() {
    let err = DragCase::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("cases/drag/e1.toml")).unwrap_err().to_string();
    assert!(err.contains("drag.shape = ellipse") && err.contains("not implemented"), "{err}");
}
