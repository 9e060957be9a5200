"""Loading and driving one JSBSim model: the only place the testbed calls JSBSim.

:class:`JSBSimModel` owns an ``FGFDMExec``. It loads any aircraft that ships in
the ``jsbsim`` wheel or lives in this package's ``models/`` folder, optionally
with extra ``<system>`` files appended (our flight controllers, written as
JSBSim FCS components so the inner loop runs in C++ at the full frame rate).
It does so without editing the original model: the model folder is mirrored
into a temporary root with symlinks, and only the top-level XML is rewritten
with the extra ``<system file=...>`` lines.

A model of ours may also be *derived* from another one instead of copying it:
``models/NAME/NAME.derive.xml`` names a ``base`` model and lists elements to
append under paths of the base's XML (:func:`derive_model_xml`). The mirror
then holds the base's folder with the derived top-level XML, so the file that
ships is exactly the difference, with its sources beside it.

Properties are read and written through cached property nodes (the fastest
access path measured for the wheel; see ``shared/README.md``). Units: JSBSim
speaks feet; this class converts at the edge, and everything it returns is SI.
"""

from __future__ import annotations

import atexit
import contextlib
import dataclasses
import os
import shutil
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable
from math import isnan
from pathlib import Path

import jsbsim

from geofence.geometry.geodesy import LocalFrame
from geofence.interface import VehicleState
from geofence.validation import ConfigError

FT_TO_M = 0.3048
M_TO_FT = 1.0 / FT_TO_M
KT_TO_MPS = 1852.0 / 3600.0

JSBSIM_ROOT = Path(jsbsim.__file__).parent
OWN_MODELS = Path(__file__).parent / "models"
OWN_SYSTEMS = Path(__file__).parent / "systems"


class UnknownAircraftError(ConfigError):
    """No JSBSim model of that name ships in the wheel or in ``aircraft/models``."""


DERIVE_SUFFIX = ".derive.xml"
"""A model folder of ours holding ``NAME.derive.xml`` instead of ``NAME.xml`` derives from a base model."""


USER_MODEL_DIRS: list[Path] = []
"""Folders of a user's own models (each holding ``NAME/NAME.xml``, like JSBSim's ``aircraft/``), searched first:
``characterize MODEL --aircraft-dir DIR`` adds one (:func:`add_model_dir`)."""


def add_model_dir(folder: Path) -> None:
    """Search ``folder`` for models before ours and the wheel's (for the rest of the process)."""
    folder = Path(folder).resolve()
    if folder not in USER_MODEL_DIRS:
        USER_MODEL_DIRS.insert(0, folder)


def _is_model(folder: Path) -> bool:
    return (folder / f"{folder.name}.xml").is_file() or (folder / f"{folder.name}{DERIVE_SUFFIX}").is_file()


def available_models() -> list[str]:
    """Names of every loadable aircraft model, our own first."""
    own = sorted(p.name for p in OWN_MODELS.glob("*") if _is_model(p))
    wheel = sorted(p.name for p in (JSBSIM_ROOT / "aircraft").glob("*") if (p / f"{p.name}.xml").is_file())
    return own + [m for m in wheel if m not in own]


def model_folder(name: str) -> Path:
    """The folder holding model ``name`` (a user's folders shadow ours, ours shadow the wheel's)."""
    for user in USER_MODEL_DIRS:
        if (user / name / f"{name}.xml").is_file():
            return user / name
    if _is_model(OWN_MODELS / name):
        return OWN_MODELS / name
    folder = JSBSIM_ROOT / "aircraft" / name
    if (folder / f"{name}.xml").is_file():
        return folder
    raise UnknownAircraftError(f"unknown aircraft model {name!r}; known: {', '.join(available_models())}")


def derive_model_xml(derive_file: Path) -> tuple[str, ET.Element]:
    """The base model's name and its top-level XML element with the derivation in ``derive_file`` applied.

    The file's root is ``<derive base="NAME" name="...">``; each ``<append to="PATH">``
    child (an ElementTree path below the base's ``<fdm_config>``, which must match exactly
    one element) has its children appended there, and a ``<fileheader>`` child replaces
    the base's. ``name`` becomes the ``<fdm_config name=...>``.
    """
    spec = ET.parse(derive_file).getroot()
    base = spec.get("base")
    if spec.tag != "derive" or not base:
        raise ConfigError(f'{derive_file}: root must be <derive base="MODEL">')
    base_folder = model_folder(base)
    if (base_folder / f"{base}{DERIVE_SUFFIX}").is_file():
        raise ConfigError(f"{derive_file}: base {base!r} is itself derived (one level only)")
    top = ET.parse(base_folder / f"{base}.xml").getroot()
    new_name = spec.get("name")
    if new_name:
        top.set("name", new_name)
    for child in spec:
        if child.tag == "fileheader":
            old = top.find("fileheader")
            index = list(top).index(old) if old is not None else 0
            if old is not None:
                top.remove(old)
            top.insert(index, child)
        elif child.tag == "append":
            found = top.findall(child.get("to", ""))
            if len(found) != 1:
                raise ConfigError(
                    f"{derive_file}: append to={child.get('to')!r}: matches {len(found)} elements of {base!r}, needs 1"
                )
            found[0].extend(list(child))
        else:
            raise ConfigError(f"{derive_file}: unknown element <{child.tag}> (expected fileheader or append)")
    return base, top


def _mirror_with_systems(name: str, extra_systems: list[Path], root: Path) -> None:
    """Mirror model ``name`` into ``root/aircraft/name`` with extra system files appended."""
    source = model_folder(name)
    derive_file = source / f"{name}{DERIVE_SUFFIX}"
    if derive_file.is_file():
        base, top = derive_model_xml(derive_file)
        folders = [model_folder(base), source]
        skip = {f"{base}.xml", derive_file.name}
    else:
        top = ET.parse(source / f"{name}.xml").getroot()
        folders = [source]
        skip = {f"{name}.xml"}
    target = root / "aircraft" / name
    target.mkdir(parents=True)
    for folder in folders:  # the derived model's own files (engines, notes) shadow the base's
        for entry in folder.iterdir():
            if entry.name not in skip:
                link = target / entry.name
                if link.is_symlink():
                    link.unlink()
                os.symlink(entry, link)
    for system in extra_systems:
        ET.SubElement(top, "system", {"file": str(Path(system).resolve())})
    ET.ElementTree(top).write(target / f"{name}.xml", xml_declaration=True, encoding="utf-8")


@contextlib.contextmanager
def quiet_native_output():
    """Silence JSBSim's C++ banner and load-time warnings (it writes to fds 1 and 2 directly).

    Set ``GFT_JSBSIM_VERBOSE=1`` to see them.
    """
    if os.environ.get("GFT_JSBSIM_VERBOSE"):
        yield
        return
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


TEMP_PREFIX = "gft-jsbsim-"
"""Prefix of the temporary model folders (in :func:`tempfile.gettempdir`)."""

_LIVE_ROOTS: set[Path] = set()
"""Temporary model folders that exist right now (only while a model loads)."""


def _remove_root(root: Path) -> None:
    shutil.rmtree(root, ignore_errors=True)
    _LIVE_ROOTS.discard(root)


def remove_temporary_folders() -> None:
    """Remove every temporary model folder this process still holds (at exit, on SIGTERM in a worker)."""
    for root in list(_LIVE_ROOTS):
        _remove_root(root)


atexit.register(remove_temporary_folders)


class JSBSimModel:
    """One JSBSim aircraft, stepped at a fixed rate, with SI accessors.

    ``dt_s`` is the JSBSim frame time (default 1/120 s). ``extra_systems`` are
    paths of JSBSim ``<system>`` XML files appended to the model.

    The model is mirrored into a temporary folder (``gft-jsbsim-*``) only for
    the load: the folder is removed as soon as JSBSim has read it (and on an
    exception, at interpreter exit, or by :func:`remove_temporary_folders` in
    a batch worker's SIGTERM handler), so none is left behind. :meth:`close`
    (or ``with JSBSimModel(...) as m:``) releases the JSBSim instance.

    ``on_mirrored(root)``, a named hook, is called once the mirror folder is
    written and before JSBSim reads it (tests use it to interrupt a load).
    """

    def __init__(
        self,
        name: str,
        dt_s: float = 1.0 / 120.0,
        extra_systems: list[Path] | None = None,
        on_mirrored: Callable[[Path], None] | None = None,
    ):
        self.name = name
        self.dt_s = dt_s
        self.closed = False
        self._root = Path(tempfile.mkdtemp(prefix=TEMP_PREFIX))
        _LIVE_ROOTS.add(self._root)
        try:
            _mirror_with_systems(name, list(extra_systems or []), self._root)
            if on_mirrored is not None:
                on_mirrored(self._root)
            with quiet_native_output():
                fdm = jsbsim.FGFDMExec(str(self._root))
                fdm.set_debug_level(0)
                fdm.set_engine_path(str(JSBSIM_ROOT / "engine"))
                fdm.set_systems_path(str(JSBSIM_ROOT / "systems"))
                fdm.set_dt(dt_s)
                loaded = fdm.load_model(name)
        finally:
            # JSBSim has read every file it needs (model, engines, systems) once load_model returns,
            # so the mirror goes at once: no folder outlives the load, even if the process is killed later
            _remove_root(self._root)
        if not loaded:
            raise UnknownAircraftError(f"JSBSim could not load aircraft model {name!r}")
        self.fdm = fdm
        self._pm = fdm.get_property_manager()
        self._nodes: dict[str, object] = {}
        self.frame: LocalFrame | None = None
        self._to_enu: Callable[[float, float, float], tuple[float, float, float]] | None = None
        self._ground_m = 0.0
        n = self.node
        self._truth_nodes = tuple(
            n(p)
            for p in (
                "simulation/sim-time-sec",
                "position/lat-geod-deg",
                "position/long-gc-deg",
                "position/geod-alt-ft",
                "position/h-agl-ft",
                "velocities/v-east-fps",
                "velocities/v-north-fps",
                "velocities/v-down-fps",
                "attitude/phi-rad",
                "attitude/theta-rad",
                "attitude/psi-rad",
                "velocities/vtrue-fps",
                "gear/wow",
            )
        )
        self._truth_getters = tuple(nd.get_double_value for nd in self._truth_nodes)
        self._wind_nodes = tuple(
            n(p) for p in ("atmosphere/wind-east-fps", "atmosphere/wind-north-fps", "atmosphere/wind-down-fps")
        )
        self._wind_setters = tuple(nd.set_double_value for nd in self._wind_nodes)

    # -- property access ---------------------------------------------------
    def node(self, prop: str):
        """The cached property node for ``prop`` (created by JSBSim if missing)."""
        node = self._nodes.get(prop)
        if node is None:
            node = self._pm.get_node(prop, True)
            self._nodes[prop] = node
        return node

    def has(self, prop: str) -> bool:
        """Whether the model has the property (without creating it)."""
        return prop in self._nodes or bool(self._pm.hasNode(prop))

    def get(self, prop: str) -> float:
        return self.node(prop).get_double_value()

    def set(self, prop: str, value: float) -> None:
        self.node(prop).set_double_value(float(value))

    # -- lifecycle -----------------------------------------------------------
    def close(self) -> None:
        """Release the JSBSim instance and any temporary folder; idempotent."""
        if self.closed:
            return
        self.closed = True
        _remove_root(self._root)
        self._nodes.clear()
        self._truth_nodes = self._truth_getters = self._wind_nodes = self._wind_setters = ()
        self._pm = None  # type: ignore[assignment]  # closed: nothing may use the instance any more
        self.fdm = None  # type: ignore[assignment]

    def __enter__(self) -> "JSBSimModel":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def reset(
        self,
        frame: LocalFrame,
        lat_deg: float,
        lon_deg: float,
        agl_m: float,
        heading_deg: float = 0.0,
        airspeed_mps: float = 0.0,
        ground_alt_m: float | None = None,
    ) -> None:
        """Place the aircraft at ``agl_m`` above flat ground at ``ground_alt_m`` (default: frame origin height).

        Set any pre-``run_ic`` controls (e.g. hover throttle) before calling this.
        """
        self.frame = frame
        self._to_enu = frame.enu_function()  # (bound once: truth() runs every step)
        self._ground_m = frame.h0_m if ground_alt_m is None else ground_alt_m
        s = self.set
        s("ic/lat-geod-deg", lat_deg)
        s("ic/long-gc-deg", lon_deg)
        s("ic/terrain-elevation-ft", self._ground_m * M_TO_FT)
        s("ic/h-agl-ft", agl_m * M_TO_FT)
        s("ic/psi-true-deg", heading_deg)
        s("ic/phi-deg", 0.0)
        s("ic/theta-deg", 0.0)
        s("ic/vt-kts", airspeed_mps / KT_TO_MPS)
        with quiet_native_output():
            ok = self.fdm.run_ic()
        if not ok:
            raise RuntimeError(f"JSBSim run_ic failed for {self.name}")

    def clear_state(self) -> None:
        """Reset every model state (rotor speeds, flight-controller filters and integrators) to the initial conditions."""
        with quiet_native_output():
            self.fdm.reset_to_initial_conditions(0)

    def step(self, n_frames: int = 1) -> None:
        """Advance ``n_frames`` JSBSim frames (``n_frames * dt_s`` seconds)."""
        run = self.fdm.run
        for _ in range(n_frames):
            run()

    def set_wind_enu(self, east_mps: float, north_mps: float, up_mps: float) -> None:
        """Air-mass velocity in m/s, ENU, as the direction the air moves *toward*."""
        set_e, set_n, set_d = self._wind_setters
        set_e(east_mps * M_TO_FT)
        set_n(north_mps * M_TO_FT)
        set_d(-up_mps * M_TO_FT)

    def truth(self) -> VehicleState:
        """Current truth state (SI, ENU about the reset frame)."""
        to_enu = self._to_enu
        if to_enu is None:
            raise RuntimeError(f"{self.name}: truth() before reset() placed the aircraft")
        # per-step path: one call per property, unrolled (a comprehension over the getters costs a third more)
        get_t, get_lat, get_lon, get_h, get_agl, get_ve, get_vn, get_vd, get_phi, get_theta, get_psi, get_vt, get_wow = (
            self._truth_getters
        )
        t = get_t()
        lat = get_lat()
        lon = get_lon()
        h_m = get_h() * FT_TO_M
        e, n, u = to_enu(lat, lon, h_m)
        if isnan(h_m) or isnan(e):
            raise FloatingPointError(f"JSBSim state of {self.name} diverged (NaN) at t={t:.2f} s")
        # Positional arguments in VehicleState's field order (checked at import below): with keywords,
        # building the 16-field state costs more than reading the 13 properties.
        return VehicleState(
            t,  # t_s
            lat,  # lat_deg
            lon,  # lon_deg
            h_m,  # alt_m
            e,  # east_m
            n,  # north_m
            u,  # up_m
            get_agl() * FT_TO_M,  # agl_m
            get_ve() * FT_TO_M,  # v_east_mps
            get_vn() * FT_TO_M,  # v_north_mps
            -get_vd() * FT_TO_M,  # v_up_mps
            get_phi(),  # roll_rad
            get_theta(),  # pitch_rad
            get_psi(),  # yaw_rad
            get_vt() * FT_TO_M,  # airspeed_mps
            get_wow() > 0.5,  # on_ground
        )


_TRUTH_FIELD_ORDER = (
    "t_s", "lat_deg", "lon_deg", "alt_m", "east_m", "north_m", "up_m", "agl_m",
    "v_east_mps", "v_north_mps", "v_up_mps", "roll_rad", "pitch_rad", "yaw_rad", "airspeed_mps", "on_ground",
)  # fmt: skip
if tuple(f.name for f in dataclasses.fields(VehicleState)) != _TRUTH_FIELD_ORDER:
    raise ImportError("VehicleState's fields changed: update JSBSimModel.truth (it passes them by position)")
