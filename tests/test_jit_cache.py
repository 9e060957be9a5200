"""The compiled kernels' cache folder is named by the sources they are built from (``geofence.jit``): numba checks a
cached kernel against its own file only, so an edit to a function another module's kernel inlines (a room formula,
the lateral search) would otherwise load stale machine code without a word."""

import shutil
from pathlib import Path

import pytest

from geofence import jit
from geofence.jit import KERNEL_PACKAGES, cache_dir_for, kernel_sources, kernel_sources_stamp

ROOT = Path(__file__).resolve().parents[1]


def _copy_sources(to: Path) -> None:
    for package in KERNEL_PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            target = to / path.relative_to(ROOT)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(path, target)


def test_the_kernel_sources_are_the_compiled_modules_and_what_they_import():
    """The stamp covers a module that defines kernels, a module whose functions they inline, and a module whose
    constants they read; not the application nor the file formats (a docstring there recompiles nothing)."""
    names = {p.relative_to(ROOT).as_posix() for p in kernel_sources(ROOT)}
    assert {"geofence/jit.py", "geofence/physics/rooms.py", "wind/field_kernel.py", "scenarios/flight/step_kernel.py"} <= names
    assert "geofence/interface.py" in names  # imported by compiled modules: its constants may be frozen in
    assert not {"scenarios/app/cli.py", "analysis/formats/fence_files.py", "analysis/report.py"} & names


def test_an_edit_to_any_kernel_source_names_a_new_folder_and_the_old_one_goes(tmp_path):
    _copy_sources(tmp_path)
    first = cache_dir_for(tmp_path)
    assert first is not None and first.name == kernel_sources_stamp(tmp_path) == kernel_sources_stamp(ROOT)
    (first / "kernel.nbi").write_text("machine code of the old sources")
    cli = tmp_path / "scenarios" / "app" / "cli.py"
    cli.write_text(cli.read_text() + "\n# not a kernel source\n")
    assert cache_dir_for(tmp_path) == first  # the application is not compiled: the cache stays
    formats = tmp_path / "analysis" / "formats" / "fence_files.py"
    formats.write_text(formats.read_text().replace('"""', '"""An edited docstring. ', 1))
    assert cache_dir_for(tmp_path) == first  # nor is a file format
    rooms = tmp_path / "geofence" / "physics" / "rooms.py"  # inlined into other modules' kernels
    rooms.write_text(rooms.read_text().replace("TWO_PI = 2.0 * math.pi", "TWO_PI = 2.0 * math.pi  # edited"))
    second = cache_dir_for(tmp_path)
    assert second is not None and second != first
    assert not first.exists()  # the stale machine code is gone


@pytest.mark.skipif(not jit.COMPILED, reason="numba not installed or disabled")
def test_this_process_caches_under_its_sources_stamp():
    import numba

    if Path(numba.config.CACHE_DIR or "").parent.name != ".numba-cache":
        pytest.skip("NUMBA_CACHE_DIR chosen by the user, or the tree and the home folder are not writable")
    assert Path(numba.config.CACHE_DIR).name == kernel_sources_stamp(ROOT)
