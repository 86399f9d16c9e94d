"""The case-file reference, made from the case file's JSON Schema (`talus schema`).

    python3 -m compare schema [--check]

writes docs/case.schema.json (the schema itself, for editors that check TOML against a
JSON Schema) and docs/guide/case-reference.md (every section and key with its type,
default and documentation, rendered from the schema). With --check nothing is written:
exit status 1 if either file is not what the schema makes now (the test suite runs it)."""

import argparse
import json
import subprocess
import sys
from pathlib import Path

from .engines import TALUS

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = ROOT / "docs" / "case.schema.json"
PAGE = ROOT / "docs" / "guide" / "case-reference.md"
ORDER = ["simulation", "contact", "material", "particles", "wall", "phase", "output", "analysis", "parallel", "compare"]


def schema():
    r = subprocess.run([str(TALUS), "schema"], capture_output=True, text=True, check=True)
    return json.loads(r.stdout)


def one_line(text):
    return " ".join((text or "").split()).replace("|", "\\|")


class Page:
    def __init__(self, s):
        self.s, self.defs, self.out, self.seen = s, s.get("definitions", {}), [], set()

    def resolve(self, node):
        """(the definition a node stands for, or the node; whether it may be absent)."""
        optional = False
        while True:
            if "$ref" in node:
                node = self.defs[node["$ref"].split("/")[-1]]
            elif "allOf" in node and len(node["allOf"]) == 1:
                node = self.resolve(node["allOf"][0])[0]
            elif "anyOf" in node and any(x.get("type") == "null" for x in node["anyOf"]):
                rest = [x for x in node["anyOf"] if x.get("type") != "null"]
                optional = True
                if len(rest) != 1:
                    return {"anyOf": rest}, optional
                node = rest[0]
            else:
                return node, optional

    def values(self, n):
        """The values of an enumeration whose variants are documented one by one (oneOf of
        constants), or None."""
        variants = n.get("oneOf") or n.get("anyOf")
        if not variants:
            return None
        vals = []
        for v in variants:
            r, _ = self.resolve(v)
            if "const" in r:
                vals.append(r["const"])
            elif "enum" in r:
                vals += r["enum"]
            else:
                return None
        return vals

    def value_docs(self, n):
        """'"a": doc; "b": doc' of an enumeration documented per variant."""
        out = []
        for v in n.get("oneOf") or n.get("anyOf") or []:
            r, _ = self.resolve(v)
            for val in ([r["const"]] if "const" in r else r.get("enum", [])):
                if r.get("description"):
                    out.append(f"{json.dumps(val)}: {one_line(r['description'])}")
        return "; ".join(out)

    def type_of(self, node):
        n, optional = self.resolve(node)
        if "enum" in n:
            t = " \\| ".join(json.dumps(v) for v in n["enum"])
        elif "const" in n:
            t = json.dumps(n["const"])
        elif self.values(n) is not None:
            t = " \\| ".join(json.dumps(v) for v in self.values(n))
        elif "oneOf" in n or "anyOf" in n:
            t = "one of the forms below"
        else:
            ty = n.get("type", "any")
            ty = [x for x in ty if x != "null"] if isinstance(ty, list) else [ty]
            if isinstance(node.get("type"), list) and "null" in node["type"]:
                optional = True
            ty = ty[0] if len(ty) == 1 else " or ".join(ty)
            if ty == "array":
                items = n.get("items", {})
                inner = self.type_of(items)
                size = f"{n['minItems']} " if n.get("minItems") is not None and n.get("minItems") == n.get("maxItems") else ""
                t = f"array of {size}{inner}"
            elif ty == "object" and "properties" in n:
                t = "table (below)"
            elif ty == "object" and "additionalProperties" in n and isinstance(n["additionalProperties"], dict):
                t = f"table of {self.type_of(n['additionalProperties'])}"
            else:
                t = {"number": "number", "integer": "integer", "string": "string", "boolean": "boolean"}.get(ty, ty)
        return t + (" (optional)" if optional else "")

    def table(self, path, n):
        props = n.get("properties", {})
        req = set(n.get("required", []))
        rows = ["| key | type | default | |", "|---|---|---|---|"]
        nested = []
        for k in sorted(props):
            v = props[k]
            d = v.get("default")
            default = "required" if k in req else ("" if d is None else f"`{json.dumps(d)}`")
            r, _ = self.resolve(v)
            desc = one_line(v.get("description") or r.get("description", ""))
            if self.values(r) is not None and self.value_docs(r):
                desc = (desc + " " if desc else "") + "(" + self.value_docs(r) + ")"
            rows.append(f"| `{k}` | {self.type_of(v)} | {default} | {desc} |")
            if r.get("type") == "array":
                r, _ = self.resolve(r.get("items", {}))
            if "properties" in r or (("oneOf" in r or "anyOf" in r) and self.values(r) is None):
                nested.append((f"{path}.{k}", r))
        self.out += rows + [""]
        for p, r in nested:
            self.section(p, r, level=3)

    def section(self, path, n, level=2):
        self.out += [f"{'#' * level} `{path}`", ""]
        if n.get("description"):
            self.out += [one_line(n["description"]).replace("\\|", "|"), ""]
        if "oneOf" in n or ("anyOf" in n and "properties" not in n):
            for k, variant in enumerate(n.get("oneOf") or n.get("anyOf")):
                v, _ = self.resolve(variant)
                tag = next((f"{key} = {json.dumps(p['const'])}" for key, p in v.get("properties", {}).items() if "const" in p), None)
                name = tag or next(iter(v.get("required", []) or v.get("properties", {}) or [f"form {k + 1}"]), f"form {k + 1}")
                self.out += [f"{'#' * (level + 1)} `{path}`: {name}", ""]
                if v.get("description"):
                    self.out += [one_line(v["description"]).replace("\\|", "|"), ""]
                if "properties" in v:
                    self.table(path, v)
                else:
                    self.out += [f"A {self.type_of(v)}.", ""]
        elif "properties" in n:
            self.table(path, n)

    def render(self):
        self.out = ["# Case-file reference", "",
                    "Every section and key of a case file, with its type, default and documentation. This page is made "
                    "from the case file's JSON Schema, which `talus schema` prints (`python3 -m compare schema` writes "
                    "both; never edit them by hand). Arrays of tables (`[[material]]`, `[[wall]]`, `[[phase]]`) take "
                    "one table per entry. Checks beyond the types (ranges, names that must exist, exactly one of two "
                    "keys) are made when the case is loaded, with a message naming the key and the value.", "",
                    "Editors check case files against the schema as one types: see [case files](cases.md#checking-a-case-file-as-you-type).", ""]
        props = self.s["properties"]
        for k in ORDER + sorted(set(props) - set(ORDER)):
            if k not in props:
                continue
            n, _ = self.resolve(props[k])
            name = k
            if n.get("type") == "array":
                n, _ = self.resolve(n.get("items", {}))
                name = f"[[{k}]]"
            else:
                name = f"[{k}]"
            self.out += [f"## `{name}`", ""]
            if props[k].get("description"):
                self.out += [one_line(props[k]["description"]).replace("\\|", "|"), ""]
            self.section(k, n, level=3) if ("oneOf" in n) else (self.out.extend([one_line(n.get("description", "")).replace("\\|", "|"), ""]) if n.get("description") else None, self.table(k, n))
        return "\n".join(self.out).rstrip() + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python3 -m compare schema", description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="write nothing; exit 1 if docs/case.schema.json or the reference page is out of date")
    a = ap.parse_args(argv)
    s = schema()
    text = json.dumps(s, indent=2) + "\n"
    page = Page(s).render()
    if a.check:
        stale = [str(p) for p, t in ((SCHEMA, text), (PAGE, page)) if not p.exists() or p.read_text() != t]
        if stale:
            print("compare schema: out of date (run python3 -m compare schema): " + ", ".join(stale), file=sys.stderr)
            return 1
        print("compare schema: docs/case.schema.json and the reference page are current")
        return 0
    SCHEMA.write_text(text)
    PAGE.write_text(page)
    print(f"wrote {SCHEMA} and {PAGE}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
