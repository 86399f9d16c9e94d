"""The Python reference, made from the module's stub (python/talus/_talus.pyi), whose
docstrings document every item for editors.

    python3 -m compare pyref [--check]

writes docs/guide/python-reference.md; with --check nothing is written, and the exit
status is 1 if the page is not what the stub makes now (the test suite runs it)."""

import argparse
import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STUB = ROOT / "python" / "talus" / "_talus.pyi"
PAGE = ROOT / "docs" / "guide" / "python-reference.md"


def signature(f):
    """`name(args) -> returns` of a function definition, as the stub writes it."""
    args = ast.unparse(f.args)
    ret = f" -> {ast.unparse(f.returns)}" if f.returns is not None else ""
    return f"{f.name}({args}){ret}"


def kind(f):
    names = {ast.unparse(d) for d in f.decorator_list}
    if "property" in names:
        return "property"
    if any(n.endswith(".setter") for n in names):
        return "setter"
    if "staticmethod" in names:
        return "staticmethod"
    return "method"


def render(stub_text):
    tree = ast.parse(stub_text)
    out = ["# Python reference", "",
           "Every item of the `talus` module, from the docstrings of its stub `python/talus/_talus.pyi` "
           "(`python3 -m compare pyref` makes this page; never edit it by hand). The [Python guide](python.md) "
           "shows the module in use.", ""]
    module_items, classes = [], []
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            classes.append(node)
        elif isinstance(node, ast.FunctionDef):
            module_items.append(node)
        elif isinstance(node, ast.AnnAssign):
            out += [f"- `talus.{ast.unparse(node.target)}: {ast.unparse(node.annotation)}`"]
    out.append("")
    for c in classes:
        bases = ", ".join(ast.unparse(b) for b in c.bases)
        out += [f"## `{c.name}`" + (f" ({bases})" if bases else ""), ""]
        doc = ast.get_docstring(c)
        if doc:
            out += [doc, ""]
        setters = {f.name for f in c.body if isinstance(f, ast.FunctionDef) and kind(f) == "setter"}
        for f in c.body:
            if not isinstance(f, ast.FunctionDef) or kind(f) == "setter":
                continue
            k = kind(f)
            if k == "property":
                ret = f": {ast.unparse(f.returns)}" if f.returns is not None else ""
                title = f"`{c.name}.{f.name}{ret}`" + (" (property, settable)" if f.name in setters else " (property)")
            else:
                title = f"`{c.name}.{signature(f)}`" + (" (static)" if k == "staticmethod" else "")
            out += [f"### {title}", ""]
            d = ast.get_docstring(f)
            out += [d if d else "(no docstring)", ""]
    if module_items:
        out += ["## Functions", ""]
        for f in module_items:
            out += [f"### `talus.{signature(f)}`", "", ast.get_docstring(f) or "(no docstring)", ""]
    return "\n".join(out).rstrip() + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m compare pyref", description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if the page is out of date")
    a = ap.parse_args(argv)
    page = render(STUB.read_text())
    if a.check:
        if not PAGE.exists() or PAGE.read_text() != page:
            print(f"compare pyref: {PAGE} is out of date (run python3 -m compare pyref)", file=sys.stderr)
            return 1
        print("compare pyref: the Python reference is current")
        return 0
    PAGE.write_text(page)
    print(f"wrote {PAGE}")
    return 0
