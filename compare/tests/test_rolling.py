"""Rolling resistance on a pile: with `contact.rolling = "cdt"` or `"epsd2"` the pile of
cases/pile.toml stands steeper and runs out less as the rolling friction coefficient
rises, and with a coefficient of 0 it is the pile without rolling resistance, bit for bit."""

import subprocess
import tomllib
from pathlib import Path

from compare import engines
from compare.case import pile_figures, read_final

ROOT = Path(__file__).resolve().parents[2]
CASE = ROOT / "cases" / "pile.toml"


def pile(tmp_path, sets):
    out = tmp_path / ("-".join(s.replace("=", "").replace("[", "").replace("]", "").replace(".", "") for s in sets) or "plain")
    cmd = [str(engines.TALUS), "run", str(CASE), "--out", str(out), "--quiet"]
    for s in sets:
        cmd += ["--set", s]
    subprocess.run(cmd, check=True, capture_output=True)
    case = tomllib.load(open(CASE, "rb"))
    return pile_figures(*read_final(out), case), (out / "final.csv").read_bytes()


def test_the_angle_of_repose_rises_with_the_rolling_friction(tmp_path):
    plain, plain_state = pile(tmp_path, [])
    for law in ("cdt", "epsd2"):
        zero, zero_state = pile(tmp_path, [f"contact.rolling={law}", "material[0].rolling_friction=0.0"])
        low, _ = pile(tmp_path, [f"contact.rolling={law}", "material[0].rolling_friction=0.1"])
        high, _ = pile(tmp_path, [f"contact.rolling={law}", "material[0].rolling_friction=0.3"])
        assert zero_state == plain_state, law
        # measured (cdt): 16.2, 20.6 and 26.9 degrees; runout 150, 87 and 71 mm
        # measured (epsd2): 16.2, 23.8 and 29.5 degrees; runout 150, 86 and 70 mm
        assert plain["angle_of_repose_deg"] + 2.0 < low["angle_of_repose_deg"] < high["angle_of_repose_deg"] - 2.0, (law, plain, low, high)
        assert plain["runout_95_m"] > low["runout_95_m"] > high["runout_95_m"], (law, plain, low, high)
