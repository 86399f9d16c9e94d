"""The case file's JSON Schema (`talus schema`): every shipped case validates against it,
a case with an unknown key or a wrong type does not, and the copy in docs/ and the
reference page made from it are current."""

import json
import subprocess
import tomllib
from pathlib import Path

import jsonschema

from compare import schema_page
from compare.engines import TALUS

ROOT = Path(__file__).resolve().parents[2]


def schema():
    return json.loads(subprocess.run([str(TALUS), "schema"], capture_output=True, text=True, check=True).stdout)


def test_every_shipped_case_validates_and_bad_ones_do_not() -> None:
    v = jsonschema.Draft7Validator(schema())
    cases = sorted(ROOT.glob("cases/*.toml")) + sorted(ROOT.glob("cases/bench/*.toml"))
    assert len(cases) > 30
    for c in cases:
        errors = [f"{list(e.absolute_path)}: {e.message}" for e in v.iter_errors(tomllib.loads(c.read_text()))]
        assert not errors, f"{c}: {errors}"
    good = tomllib.loads((ROOT / "cases" / "SC-wall.toml").read_text())
    for path, value in ((("simulation", "timestepp"), 1e-5), (("contact", "model"), "hertzz"), (("simulation", "gravity"), [0.0, 9.81]),
                        (("output", "fields"), {"width": "wide", "profile": "z", "interval": 1.0})):
        bad = json.loads(json.dumps(good))
        bad[path[0]][path[1]] = value
        assert list(v.iter_errors(bad)), f"{path} = {value!r} validates"


def test_the_schema_copy_and_the_reference_page_are_current() -> None:
    assert schema_page.main(["--check"]) == 0, "run python3 -m compare schema"
