"""Print the layer-level import matrix of this checkout: python docs/import_table.py (from the repository root).

Rows and columns are the layers, bottom up: the packages, with geofence/ split into its
sub-packages (its top-level modules interface, validation and jit first, then physics, geometry, estimation,
margins, recovery, unit) and scenarios/ into its subpackages (airspace: the park generator; definition: scenario data; campaign: the case generator;
flight: the simulated flight; app: CLI, batch, experiments). A cell counts the files of the row layer that import the column
layer; a number above the diagonal would be an upward import. The architecture test
(tests/test_architecture.py) fails on any.
"""

import ast
from collections import defaultdict
from pathlib import Path

LAYERS = [
    "geofence",
    "geofence.physics",
    "geofence.geometry",
    "geofence.estimation",
    "geofence.margins",
    "geofence.recovery",
    "geofence.unit",
    "wind",
    "aircraft",
    "analysis",
    "scenarios.airspace",
    "scenarios.definition",
    "scenarios.campaign",
    "scenarios.link",
    "scenarios.flight",
    "scenarios.app",
]


def layer_of(module: str) -> str | None:
    """The layer a dotted module name belongs to (the longest matching prefix), or None if not ours."""
    best = None
    for layer in LAYERS:
        if module == layer or module.startswith(layer + "."):
            best = layer if best is None or len(layer) > len(best) else best
    return best


def main() -> None:
    m: dict[tuple[str, str], set[str]] = defaultdict(set)
    for f in sorted(Path(".").rglob("*.py")):
        parts = f.with_suffix("").parts
        if not parts or parts[0] not in {"geofence", "wind", "aircraft", "analysis", "scenarios"}:
            continue
        own = layer_of(".".join(parts))
        if own is None:  # scenarios/__init__.py and the data scripts beside the YAML files
            continue
        for node in ast.walk(ast.parse(f.read_text())):
            if isinstance(node, ast.Import):
                mods = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                mods = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
            else:
                continue
            for mod in mods:
                target = layer_of(mod)
                if target is not None and target != own:
                    m[(own, target)].add(str(f))
    print("| imports → | " + " | ".join(LAYERS) + " |")
    print("|---|" + "---|" * len(LAYERS))
    for i, p in enumerate(LAYERS):
        cells = []
        for j, q in enumerate(LAYERS):
            n = len(m[(p, q)])
            cells.append("·" if n == 0 else (f"**{n} ↑**" if j > i else str(n)))
        print(f"| **{p}** | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
