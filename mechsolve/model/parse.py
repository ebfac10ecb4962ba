"""Turn the plain data of a mechanism file into a validated :class:`Mechanism`.

The file format is documented in docs/reference/file.md (its tables generated from
:mod:`mechsolve.model.keys`). Each section is read by one function;
every mistake raises :class:`~mechsolve.base.errors.InputError` with the file, the key path
and the line. Unknown keys get a did-you-mean suggestion.

The sections are read by the modules beside this one: :mod:`.reader` (typed values with
their key path and line), :mod:`.read_geometry` (units, ground, links, masses),
:mod:`.read_loads`, :mod:`.read_joints`, :mod:`.read_motion` (driver, motion laws,
sweep, assembly, outputs, solver) and :mod:`.read_machine` (requirements, motor,
flywheel, simulation, instants, torque problems); this module puts a file together.
"""

from __future__ import annotations

import math
from pathlib import Path

from mechsolve.joints.slider import read_line
from mechsolve.model import (
    STANDARD_G,
    Assembly,
    Mechanism,
    Outputs,
    SolverOptions,
    keys,
)
from mechsolve.model.read_geometry import (
    LINK_KEYS,
    read_gravity,
    read_ground,
    read_link,
    read_links,
    read_mass,
    read_point,
    read_units,
)
from mechsolve.model.read_joints import pin_names, read_joint, read_joints, read_pin
from mechsolve.model.read_loads import LOAD_KEYS, LOAD_KINDS, read_loads
from mechsolve.model.read_machine import (
    TORQUE_KEYS,
    is_torque_problem,
    read_flywheel,
    read_instants,
    read_motor,
    read_motors,
    read_requirements,
    read_simulation,
    read_torque_problem,
)
from mechsolve.model.read_motion import (
    METHODS,
    read_assembly,
    read_driver,
    read_law,
    read_motion,
    read_outputs,
    read_relative,
    read_solver,
    read_sweep,
    read_time_sweep,
)
from mechsolve.model.reader import Reader
from mechsolve.model.source import Source, load_file, load_text
from mechsolve.model.validate import suggest

TOP_KEYS = keys.TOP.allowed  # "study" and "cam" are read by their own commands, not run

__all__ = [
    "LINK_KEYS",
    "LOAD_KEYS",
    "LOAD_KINDS",
    "METHODS",
    "TOP_KEYS",
    "TORQUE_KEYS",
    "Reader",
    "from_source",
    "is_torque_problem",
    "load",
    "loads",
    "pin_names",
    "read_assembly",
    "read_driver",
    "read_flywheel",
    "read_gravity",
    "read_ground",
    "read_instants",
    "read_joint",
    "read_joints",
    "read_law",
    "read_line",
    "read_link",
    "read_links",
    "read_loads",
    "read_mass",
    "read_motion",
    "read_motor",
    "read_motors",
    "read_outputs",
    "read_pin",
    "read_point",
    "read_relative",
    "read_requirements",
    "read_simulation",
    "read_solver",
    "read_sweep",
    "read_time_sweep",
    "read_torque_problem",
    "read_units",
    "variants",
]


def from_source(src: Source, variant: str | None = None) -> Mechanism:
    """Build and validate a :class:`Mechanism` from a parsed file."""
    if variant is not None:
        src = src.with_variant(variant)
    r = Reader(src)
    data = src.data
    for key in data:
        if key not in TOP_KEYS:
            raise src.error(
                (key,),
                f"unknown section {key!r}"
                + suggest(key, list(TOP_KEYS))
                + f"; sections are: {', '.join(TOP_KEYS)}",
            )
    if "variants" in data and variant is None and not isinstance(data["variants"], dict):
        raise src.error(("variants",), "'variants' must map variant names to overrides")
    if "units" in data:
        read_units(r, data["units"])
    for key in ("links", "joints"):
        if key not in data:
            other = [
                f"a {what} (mechsolve {cmd} FILE)"
                for sec, what, cmd in (
                    ("cam", "cam design", "cam"),
                    ("torque", "torque curve", "flywheel"),
                )
                if sec in data
            ]
            raise src.error(
                (),
                f"the file has no '{key}' section"
                + (f": it is {other[0]}, not a mechanism" if other else ""),
            )
    gravity = read_gravity(r, data["gravity"]) if "gravity" in data else None
    g = math.hypot(*gravity) if gravity is not None and any(gravity) else STANDARD_G
    ground = read_ground(r, data.get("ground"))
    links = read_links(r, data["links"], g)
    joints = read_joints(r, data["joints"], ground, links)
    loads = read_loads(r, data["loads"], ground, links, joints) if "loads" in data else []
    driver = read_driver(r, data["driver"], joints) if "driver" in data else None
    linear = driver is not None and any(
        j.coordinate == "length" and j.name == driver.joint for j in joints
    )
    name = data.get("name", Path(src.file).stem if src.file else "mechanism")
    if not isinstance(name, str):
        raise src.error(("name",), "the name must be text")
    if "description" in data and not isinstance(data["description"], (str, type(None))):
        raise src.error(("description",), "the description must be text")
    mech = Mechanism(
        name=name,
        ground=ground,
        links=links,
        joints=joints,
        driver=driver,
        sweep=read_sweep(r, data.get("sweep"), driver, linear),
        assembly=read_assembly(r, data["assembly"]) if "assembly" in data else Assembly(),
        outputs=read_outputs(r, data["outputs"]) if "outputs" in data else Outputs(),
        solver=read_solver(r, data["solver"]) if "solver" in data else SolverOptions(),
        gravity=gravity,
        loads=loads,
        length_unit=r.length_unit,
        angle_unit=r.angle_unit if _names_angle(data.get("units")) else None,
        source=src,
    )
    if "instants" in data:
        mech.instants = read_instants(r, data["instants"], linear)
    if "motor" in data:
        mech.motor = read_motor(r, data["motor"], driver, linear)
    if "motors" in data:
        mech.motors = read_motors(r, data["motors"], mech.joints)
    if "flywheel" in data:
        mech.flywheel = read_flywheel(r, data["flywheel"], links)
    if "simulate" in data:
        mech.simulation = read_simulation(r, data["simulate"], linear)
    if "requirements" in data:
        mech.requirements = read_requirements(r, data["requirements"], linear)
    return mech.validate()


def load(path: str | Path, variant: str | None = None) -> Mechanism:
    """Read a mechanism file and return the validated :class:`Mechanism`.

    Parameters
    ----------
    path
        The YAML file.
    variant
        The name of an entry of the file's ``variants`` section to apply.
    """
    return from_source(load_file(path), variant)


def loads(text: str, variant: str | None = None, file: str | None = None) -> Mechanism:
    """Like :func:`load`, from YAML text."""
    return from_source(load_text(text, file), variant)


def variants(path: str | Path) -> list[str]:
    """Names of the variants a mechanism file defines."""
    src = load_file(path)
    v = src.data.get("variants")
    return list(v) if isinstance(v, dict) else []


def _names_angle(units: object) -> bool:
    """Whether the file's ``units:`` names the angle unit."""
    return isinstance(units, dict) and "angle" in units
