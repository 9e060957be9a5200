"""Package boundaries: JSBSim only behind aircraft/, and the geofence knows no airframe."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]


def imported_modules(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


# The layers, bottom up (docs/architecture.md): geofence and wind (pure math) -> aircraft (JSBSim behind one
# adapter) and analysis (arrays in, numbers and figures out) -> scenarios (data, the simulated flight, the
# application). A package may import only from the layers below it.
LAYER_FORBIDDEN = [
    ("geofence", {"jsbsim", "aircraft", "scenarios", "wind", "analysis"}),
    ("wind", {"jsbsim", "aircraft", "scenarios", "geofence", "analysis"}),
    ("aircraft", {"scenarios", "analysis"}),
    ("analysis", {"jsbsim", "aircraft", "scenarios"}),
]


@pytest.mark.parametrize("package, forbidden", LAYER_FORBIDDEN)
def test_package_does_not_import(package, forbidden):
    offenders = {
        str(p.relative_to(ROOT)): sorted(imported_modules(p) & forbidden) for p in (ROOT / package).rglob("*.py") if imported_modules(p) & forbidden
    }
    assert offenders == {}


def test_only_the_model_loader_imports_jsbsim():
    users = sorted(str(p.relative_to(ROOT)) for p in ROOT.rglob("*.py") if "tests" not in p.parts and "bench" not in p.parts and "jsbsim" in imported_modules(p))
    assert users == ["aircraft/jsbsim_model.py"]
