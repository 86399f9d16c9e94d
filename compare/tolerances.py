"""Tolerances of the comparisons (issue: cross-validation). A figure outside its
tolerance makes `python -m compare` exit non-zero.

SC: talus, set to the convention of the reference it is compared with, against
that reference. The absolute floors keep relative tests meaningful for figures
that are near zero (e.g. the spin after a near-normal impact).
"""

# (kind, value, absolute floor)
# The tolerances were 0.005 on restitution, 1% on duration and overlap, 2%
# on peak force and on the oblique rebound and spin. They are tightened to 1e-6
# because the results allow it: talus set to a reference's convention integrates
# the same discrete equations, and the measured differences are round-off
# (LIGGGHTS: at most 1e-13 relative) or the reference's printed precision (YADE:
# at most 2e-9 relative) over every SC run of `scripts/compare_all.sh`.
SC = {
    "restitution": ("abs", 1e-6, 0.0),
    "contact_duration_s": ("rel", 1e-6, 0.0),
    "max_overlap_m": ("rel", 1e-6, 0.0),
    "max_normal_force_n": ("rel", 1e-6, 0.0),
}
SC_OBLIQUE = {
    "tangential_rebound_m_s": ("rel", 1e-6, 1e-3),
    "spin_rad_s": ("rel", 1e-6, 0.5),
}
# H1-small
H1_DISCHARGE_RATE_REL = 0.10       # talus within 10% of each reference
H1_FORCE_SPLIT_OF_WEIGHT = 0.05    # walls vs gate split between engines, as a fraction of the weight
H1_BALANCE = 0.01                  # in each engine walls + gate = weight within 1%
# Beverloo's correlation (stated): C = 0.58, k = 1.5, bulk density = 0.6 rho_particle,
# square orifice of side D treated as a circle of diameter D.
BEVERLOO_C = 0.58
BEVERLOO_K = 1.5
BULK_FRACTION = 0.6


def check(key, talus, ref, table):
    """(ok, difference as printed) of one figure."""
    kind, tol, floor = table[key]
    diff = talus - ref
    if kind == "abs":
        return abs(diff) <= tol, diff
    scale = max(abs(ref), floor)
    return abs(diff) <= tol * scale, diff / scale if scale else 0.0
