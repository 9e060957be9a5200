"""Print the package-level import matrix of this checkout: python docs/import_table.py (from the repository root).

A cell counts the files of the row package that import the column package; the architecture test
(tests/test_architecture.py) fails on any import above the diagonal of the layer order.
"""
import ast
from collections import defaultdict
from pathlib import Path

PKG = ["geofence", "wind", "aircraft", "analysis", "scenarios"]
m = defaultdict(set)
for p in PKG:
    for f in Path(p).rglob("*.py"):
        for node in ast.walk(ast.parse(f.read_text())):
            mods = [a.name for a in node.names] if isinstance(node, ast.Import) else (
                [node.module] if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 else [])
            for mod in mods:
                top = mod.split(".")[0]
                if top in PKG and top != p:
                    m[(p, top)].add(str(f))
print("| imports → | " + " | ".join(PKG) + " |")
print("|---|" + "---|" * len(PKG))
for p in PKG:
    print(f"| **{p}** | " + " | ".join(str(len(m[(p, q)])) if m[(p, q)] else "·" for q in PKG) + " |")
