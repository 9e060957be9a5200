"""Package boundaries: JSBSim only behind aircraft/, and the geofence knows no airframe."""

import ast
import sys
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
    ("wind", {"jsbsim", "aircraft", "scenarios", "analysis"}),  # geofence: only its validation kit (below)
    ("aircraft", {"scenarios", "analysis"}),
    ("analysis", {"jsbsim", "aircraft", "scenarios"}),
]


@pytest.mark.parametrize("package, forbidden", LAYER_FORBIDDEN)
def test_package_does_not_import(package, forbidden):
    offenders = {
        str(p.relative_to(ROOT)): sorted(imported_modules(p) & forbidden)
        for p in (ROOT / package).rglob("*.py")
        if imported_modules(p) & forbidden
    }
    assert offenders == {}


SHARED_LEAVES = {"geofence.validation": set(), "geofence.jit": {"numba"}}
"""The leaves of geofence that wind may import, and the third-party packages each may use."""


def test_wind_imports_only_the_shared_leaves_from_geofence():
    """The two bottom packages share two leaves: wind may import geofence.validation (the configuration kit) and
    geofence.jit (the optional compiler), and nothing else of geofence."""
    uses = {m for p in (ROOT / "wind").rglob("*.py") for m in imported_dotted(p) if m.split(".")[0] == "geofence"}
    assert uses and all(any(m == leaf or m.startswith(leaf + ".") for leaf in SHARED_LEAVES) for m in uses), uses


@pytest.mark.parametrize("leaf", sorted(SHARED_LEAVES))
def test_the_shared_leaves_are_leaves(leaf):
    """Each imports the standard library only, and its one third-party package (no relative imports, nothing of ours)."""
    path = ROOT / (leaf.replace(".", "/") + ".py")
    tree = ast.parse(path.read_text())
    assert not any(isinstance(n, ast.ImportFrom) and n.level > 0 for n in ast.walk(tree))
    outside = sorted(m for m in imported_modules(path) if m not in sys.stdlib_module_names)
    assert set(outside) <= SHARED_LEAVES[leaf], outside


def imported_dotted(path: Path) -> set[str]:
    """Every absolute module name ``path`` imports, dotted in full (``scenarios.flight.runner``)."""
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


# Inside scenarios/, bottom up: airspace (the park generator, data) -> definition (scenario data) -> campaign (the
# case generator) -> link (the MAVLink vocabulary) -> flight (the simulated flight) -> app (CLI, batch, experiments).
SCENARIO_LAYER_FORBIDDEN = [
    (
        "scenarios/airspace",
        ("scenarios.definition", "scenarios.campaign", "scenarios.link", "scenarios.flight", "scenarios.app"),
    ),
    ("scenarios/definition", ("scenarios.campaign", "scenarios.link", "scenarios.flight", "scenarios.app")),
    ("scenarios/campaign", ("scenarios.link", "scenarios.flight", "scenarios.app")),
    ("scenarios/link", ("scenarios.flight", "scenarios.app")),
    ("scenarios/flight", ("scenarios.campaign", "scenarios.app")),
]


@pytest.mark.parametrize("folder, forbidden", SCENARIO_LAYER_FORBIDDEN)
def test_scenario_layers_import_one_way(folder, forbidden):
    offenders = {}
    for p in (ROOT / folder).rglob("*.py"):
        bad = sorted(m for m in imported_dotted(p) if m.startswith(forbidden))
        if bad:
            offenders[str(p.relative_to(ROOT))] = bad
    assert offenders == {}


# Inside geofence/, bottom up (docs/architecture.md): the shared leaves and the unit's vocabulary (jit, validation,
# interface: top-level modules) -> physics (how the aircraft moves, the rooms its manoeuvres need) -> geometry
# (where the fence is) -> estimation (where the aircraft is) -> margins (how close to acting) -> recovery (the
# way back) -> unit (the state machine, its configuration and pre-flight check). A sub-package imports only
# from the top-level modules and the sub-packages below it.
GEOFENCE_LAYERS = ["physics", "geometry", "estimation", "margins", "recovery", "unit"]


@pytest.mark.parametrize("layer", GEOFENCE_LAYERS)
def test_geofence_subpackages_import_one_way(layer):
    above = tuple(f"geofence.{q}" for q in GEOFENCE_LAYERS[GEOFENCE_LAYERS.index(layer) + 1 :])
    offenders = {}
    for p in (ROOT / "geofence" / layer).rglob("*.py"):
        bad = sorted(m for m in imported_dotted(p) if m.startswith(above) and m.split(".")[1] != layer)
        if bad:
            offenders[str(p.relative_to(ROOT))] = bad
    assert offenders == {}


def test_geofence_top_level_modules_are_its_vocabulary():
    """Only the shared leaves and the unit's inputs and outputs sit at geofence/'s top level, and they import no
    sub-package: everything else lives in a sub-package by question."""
    flat = sorted(p.stem for p in (ROOT / "geofence").glob("*.py") if p.name != "__init__.py")
    assert flat == ["interface", "jit", "validation"]
    for stem in flat:
        uses = {m for m in imported_dotted(ROOT / "geofence" / f"{stem}.py") if m.startswith("geofence.")}
        assert all(m.split(".")[1] in flat for m in uses), (stem, uses)
    subs = sorted(p.name for p in (ROOT / "geofence").iterdir() if (p / "__init__.py").exists())
    assert subs == sorted(GEOFENCE_LAYERS)


def test_scenarios_has_no_flat_modules_left():
    """Every module of scenarios/ lives in one of its layers (airspace, definition, campaign, flight, app)."""
    flat = sorted(p.name for p in (ROOT / "scenarios").glob("*.py") if p.name != "__init__.py")
    assert flat == []


def test_no_private_names_imported_across_packages():
    """``from pkg.mod import _private`` only from a sibling module of the same package (a compiled kernel's
    jitable parts are shared inside its sub-package, ``geofence/recovery/``): a private name never leaves its
    package (tests included)."""
    offenders = []
    for p in ROOT.rglob("*.py"):
        if {".git", "build"} & set(p.parts) or "egg-info" in str(p):
            continue
        package = ".".join(p.relative_to(ROOT).parts[:-1])
        for node in ast.walk(ast.parse(p.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0 and node.module != "__future__":
                private = [a.name for a in node.names if a.name.startswith("_")]
                if private and node.module.rsplit(".", 1)[0] != package:
                    offenders.append(f"{p.relative_to(ROOT)}: from {node.module} import {', '.join(private)}")
    assert offenders == []


def test_only_the_model_loader_imports_jsbsim():
    users = sorted(
        str(p.relative_to(ROOT))
        for p in ROOT.rglob("*.py")
        if "tests" not in p.parts and "bench" not in p.parts and "jsbsim" in imported_modules(p)
    )
    assert users == ["aircraft/jsbsim_model.py"]


PROJECT_PACKAGES = ("aircraft", "analysis", "geofence", "scenarios", "wind")


def test_no_project_code_is_monkeypatched():
    """Tests reach project code through named hooks and parameters, never ``monkeypatch.setattr`` / ``mock.patch``."""
    offenders = []
    for p in sorted((ROOT / "tests").rglob("*.py")) + sorted((ROOT / "bench").rglob("*.py")):
        tree = ast.parse(p.read_text())
        project_names = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                project_names.update(
                    (a.asname or a.name.split(".")[0]) for a in node.names if a.name.startswith(PROJECT_PACKAGES)
                )
            elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith(PROJECT_PACKAGES):
                project_names.update(a.asname or a.name for a in node.names)
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Call) and node.args):
                continue
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else (f.id if isinstance(f, ast.Name) else "")
            if name not in {"setattr", "patch", "object", "setitem", "delattr"}:
                continue
            target = node.args[0]
            hit = (isinstance(target, ast.Name) and target.id in project_names) or (
                isinstance(target, ast.Constant) and isinstance(target.value, str) and target.value.startswith(PROJECT_PACKAGES)
            )
            if hit and name != "setattr" or (hit and isinstance(f, ast.Attribute)):
                offenders.append(f"{p.relative_to(ROOT)}:{node.lineno}")
    assert offenders == []


FILE_READING = ("open(", ".read_text(", ".read_bytes(", ".is_file(", "json.load", "import yaml", "pathlib")
"""What reading a file looks like in a module's text."""


def test_nothing_in_the_geofence_reads_a_file():
    """The unit reads no file: formats are adapters above it (analysis/formats/, the scenario loader). Only its
    compiler plumbing (geofence/jit.py: numba's cache folder) touches the file system."""
    readers = {
        str(p.relative_to(ROOT)): [w for w in FILE_READING if w in p.read_text()]
        for p in (ROOT / "geofence").rglob("*.py")
        if p.name != "jit.py"
    }
    assert {k: v for k, v in readers.items() if v} == {}


def test_the_public_api_is_reexported_from_the_package():
    import geofence

    for name in geofence.__all__:
        obj = getattr(geofence, name)
        assert obj.__name__ == name and obj.__module__.startswith("geofence."), name
    with pytest.raises(AttributeError):
        geofence.no_such_name  # noqa: B018


def imported_test_modules(tree: ast.AST) -> list[str]:
    """The ``test_*`` modules an (already parsed) module imports, anywhere in it (function-local imports too):
    ``import test_x``, ``from test_x import y``, ``from tests.test_x import y``, ``from tests import test_x``,
    ``from . import test_x``."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if any(p.startswith("test_") for p in a.name.split("."))]
        elif isinstance(node, ast.ImportFrom):
            parts = node.module.split(".") if node.module else []
            if any(p.startswith("test_") for p in parts):
                found.append(node.module or "")
            elif node.level > 0 or parts[-1:] == ["tests"]:  # a package's test modules, by name
                found += [a.name for a in node.names if a.name.startswith("test_")]
    return found


def test_test_modules_do_not_import_each_other():
    """Shared helpers live in one support module (tests/support.py); a test module imports them from there, never
    from another test module (``support`` and ``conftest`` are fine)."""
    caught = "import test_a\nfrom test_b import x\nfrom tests.test_c import y\nfrom . import test_d\nfrom support import z\n"
    assert imported_test_modules(ast.parse(caught)) == ["test_a", "test_b", "tests.test_c", "test_d"]
    offenders = {
        str(p.relative_to(ROOT)): found
        for p in sorted((ROOT / "tests").rglob("*.py"))
        if (found := imported_test_modules(ast.parse(p.read_text())))
    }
    assert offenders == {}
