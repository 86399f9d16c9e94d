"""Figures from raw time series: the one piece of code that measures every engine.

SC series: CSV with `time_s` and per sphere `p{k}_{x,y,z}_m`, `p{k}_{vx,vy,vz}_m_s`,
`p{k}_{wx,wy,wz}_rad_s`, `p{k}_{fx,fy,fz}_n` (k = 1, and 2 for SC-pair).
"""
import csv
import math

import numpy as np

from .setups import R


def read_series(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path}: no rows")
    cols = rows[0].keys()
    return {c: np.array([float(r[c]) for r in rows]) for c in cols if c != "phase"}



def _v3(s, prefix, names):
    return np.stack([s[f"{prefix}{n}"] for n in names], axis=1)


def sc_figures(path, setup):
    """Restitution, contact duration, peak overlap and normal force, tangential rebound
    and spin of one single collision, from its time series."""
    s = read_series(path)
    t = s["time_s"]
    x1 = _v3(s, "p1_", ["x_m", "y_m", "z_m"])
    v1 = _v3(s, "p1_", ["vx_m_s", "vy_m_s", "vz_m_s"])
    w1 = _v3(s, "p1_", ["wx_rad_s", "wy_rad_s", "wz_rad_s"])
    f1 = _v3(s, "p1_", ["fx_n", "fy_n", "fz_n"])
    if setup == "SC-pair":
        x2 = _v3(s, "p2_", ["x_m", "y_m", "z_m"])
        v2 = _v3(s, "p2_", ["vx_m_s", "vy_m_s", "vz_m_s"])
        w2 = _v3(s, "p2_", ["wx_rad_s", "wy_rad_s", "wz_rad_s"])
        n = x1[0] - x2[0]
        n = n / np.linalg.norm(n)
        overlap = 2 * R - np.linalg.norm(x1 - x2, axis=1)
        vrel = v1 - v2
    else:
        n = np.array([0.0, 0.0, 1.0])
        overlap = R - x1[:, 2]
        vrel = v1
    # contact start and end: linear interpolation of the overlap's zero crossings
    inside = overlap > 0
    if not inside.any():
        raise ValueError(f"{path}: the spheres never touched")
    k0 = int(np.argmax(inside))
    k1 = k0 + int(np.argmax(~inside[k0:])) if (~inside[k0:]).any() else None
    if k1 is None or k0 == 0:
        raise ValueError(f"{path}: the contact did not both start and end inside the series")
    ts = t[k0 - 1] + (t[k0] - t[k0 - 1]) * (-overlap[k0 - 1]) / (overlap[k0] - overlap[k0 - 1])
    te = t[k1 - 1] + (t[k1] - t[k1 - 1]) * overlap[k1 - 1] / (overlap[k1 - 1] - overlap[k1])
    vin, vout = vrel[0], vrel[-1]
    vt_in = vin - n * vin.dot(n)
    # the tangential frame (as talus's src/analysis.rs `tangential_frame`): the incoming
    # tangential velocity; else the slip of the contact point due to spin; else none
    slip = np.cross(w1[0], -R * n)
    if setup == "SC-pair":
        slip = slip - np.cross(w2[0], R * n)
    slip = slip - n * slip.dot(n)
    if np.linalg.norm(vt_in) > 0:
        tdir = vt_in / np.linalg.norm(vt_in)
    elif np.linalg.norm(slip) > 0:
        tdir = slip / np.linalg.norm(slip)
    else:
        tdir = np.zeros(3)
    axis = np.cross(n, tdir)
    fig = {
        "restitution": float(-vout.dot(n) / vin.dot(n)),
        "contact_duration_s": float(te - ts),
        "max_overlap_m": float(overlap[inside].max()),
        "max_normal_force_n": float(np.abs(f1[inside] @ n).max()),
        "tangential_rebound_m_s": float(vout.dot(tdir)),
        "spin_rad_s": float(w1[-1].dot(axis)),
    }
    if np.linalg.norm(vt_in) > 0:
        fig["tangential_restitution"] = float(vout.dot(tdir) / vt_in.dot(tdir))
    return fig


def discharge_rate(times, mass_below, total_mass):
    """Least-squares slope of discharged mass against time between 20% and 80% of the total."""
    t = np.asarray(times)
    m = np.asarray(mass_below)
    sel = (m >= 0.2 * total_mass) & (m <= 0.8 * total_mass)
    if sel.sum() < 3:
        return None
    return float(np.polyfit(t[sel], m[sel], 1)[0])


def beverloo(rho_bulk, d_orifice, d_particle, c=0.58, k=1.5, g=9.81, square=True):
    """Beverloo's correlation W = C rho_b sqrt(g) (D - k d)^(5/2); for a square orifice of
    side D the circular diameter is replaced by the side (an approximation we state)."""
    return c * rho_bulk * math.sqrt(g) * (d_orifice - k * d_particle) ** 2.5
