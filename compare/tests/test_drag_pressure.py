"""Drag against confining pressure (cases/drag-pressure.toml, python -m compare.drag_pressure):
the servo lid holds its line load P through the press and the drag, and the drag on the
pushed cylinder grows in proportion to P once P outweighs the bed's own weight (the drag
paper's drag ~ P D_c)."""

import numpy as np

from compare import drag_pressure
from compare.case import read_probes


def test_the_servo_lid_holds_p_and_the_drag_grows_in_proportion_to_it(tmp_path):
    figs = {}
    for p in (3.0e3, 3.0e4):
        out = tmp_path / f"P{p:g}"
        figs[p] = drag_pressure.at(p, "talus", out)
        s = read_probes(out / "probes.csv")
        # the lid's load over the drag window, against its target P x 0.02 m
        sel = (s["time_s"] > 0.0025) & (s["time_s"] < 0.0045)
        load = s["lid_force_y_n"][sel].mean()
        assert abs(load - p * 0.02) < 0.05 * p * 0.02, (p, load)
        # the press phase ends with the lid's load at its target (within 3% in the
        # mean, 5% at every row: the bed still settles beneath it)
        pressed = s["lid_force_y_n"][(s["phase"] == "press") & (s["time_s"] > 0.0018)]
        assert abs(pressed.mean() - p * 0.02) < 0.03 * p * 0.02, (p, pressed)
        assert np.all(np.abs(pressed - p * 0.02) < 0.05 * p * 0.02), (p, pressed)
    low, high = figs[3.0e3], figs[3.0e4]
    # measured: drag 33.7 and 275 N, drag / (P D_c) 3.54 and 2.89: P ten times, the drag
    # eight times; drag / (P D_c) within a factor 1.5 (it falls slowly: the bed's weight
    # and the granules' inertia count for less as P grows)
    ratio = high["mean_drag_n"] / low["mean_drag_n"]
    assert 6.5 < ratio < 13.0, (low, high)
    assert 2.0 < high["drag_per_p_dc"] < 5.0, high
    assert 1 / 1.5 < high["drag_per_p_dc"] / low["drag_per_p_dc"] < 1.5, (low, high)
