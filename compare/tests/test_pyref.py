"""The Python reference page is current with the stub, and the stub documents every
public item the compiled module has (so the page does too)."""

import talus

from compare import pyref


def test_the_python_reference_is_current() -> None:
    assert pyref.main(["--check"]) == 0, "run python3 -m compare pyref"


def test_the_stub_documents_every_public_item_of_the_module() -> None:
    page = pyref.PAGE.read_text()
    for cls in (talus.Simulation, talus.Wall, talus.Walls):
        for name in dir(cls):
            if not name.startswith("_"):
                assert f"`{cls.__name__}.{name}" in page, f"{cls.__name__}.{name} is not in the stub"
    for name in ("drag", "cloud", "InputError", "RunError"):
        assert hasattr(talus, name) and name in page
