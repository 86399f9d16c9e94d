"""Every command README.md shows in its tour is run, as a user types it, from the
repository root with talus on the PATH; the two set-up commands are not (CI runs
them). The Python block is run as a script. The tour says the serial and the
two-rank run end in the same state: so must they."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SETUP = {"bash scripts/install.sh && bash scripts/demo.sh", "bash scripts/test.sh"}


def tour():
    """The tour's shell commands (indented lines) and Python blocks, in order."""
    text = (ROOT / "README.md").read_text()
    start = text.index("## A five-minute tour")
    end = text.index("\n## ", start + 1)
    part = text[start:end]
    commands, python = [], []
    for block in re.findall(r"```python\n(.*?)```", part, re.S):
        python.append(block)
    part = re.sub(r"```.*?```", "", part, flags=re.S)
    for line in part.splitlines():
        if line.startswith("    ") and line.strip():
            commands.append(line.strip())
    return commands, python


def test_the_readme_tour_runs_as_shown(tmp_path: Path) -> None:
    commands, python = tour()
    assert len(commands) >= 8 and python, (commands, python)
    assert not SETUP & set(commands)
    env = dict(os.environ, PATH=f"{ROOT / 'target' / 'release'}:{os.environ['PATH']}")
    for c in commands:
        if c.startswith("export PATH="):
            continue  # done above, as the tour says
        r = subprocess.run(["bash", "-c", c], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, f"README command failed: {c}\n{r.stdout[-2000:]}\n{r.stderr[-2000:]}"
        if c.startswith("grep state_hash"):
            hashes = {line.split(":", 1)[1].strip().strip(",") for line in r.stdout.splitlines() if "state_hash" in line}
            assert len(hashes) == 1, f"the tour's serial and two-rank runs differ: {r.stdout}"
    for block in python:
        script = tmp_path / "tour.py"
        script.write_text(block)
        r = subprocess.run([sys.executable, str(script)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=600)
        assert r.returncode == 0, f"README Python block failed:\n{block}\n{r.stderr[-2000:]}"
