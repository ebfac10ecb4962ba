"""The keys of a mechanism file, declared once.

Each mapping of the file format is a :class:`Section`: its keys in the order the error
messages list them, which of them are required, what kind of value each takes and a
one-line description. The parser (:mod:`mechsolve.model.parse`) reads its allowed and
required keys from here; :mod:`mechsolve.analyses.schema.build` turns the same declarations into
the JSON Schema that editors use for completion and hover help.

The value kinds are small immutable descriptions (:class:`Kind`): a quantity of a
dimension (``"110 mm"`` or a number in the file's units), coordinates, a name, a list of
names, a condition or expression, a number, a choice, a list, a mapping of names to
values, another section, or one of several of these.

The ``cam:`` and ``study:`` sections are read by their own modules
(:mod:`mechsolve.analyses.cam.model`, :mod:`mechsolve.analyses.study.designs`) from their
own key constants;
they are described here for the schema only, and the schema's generator checks that the
keys agree.
"""

from __future__ import annotations

from mechsolve.base.keyspec import (  # noqa: F401 (the vocabulary, re-exported)
    ANGLE,
    ANY,
    CONDITION,
    DESCRIPTION,
    FLAG,
    JOINT_FRICTION,
    LENGTH,
    NULL,
    TEXT,
    XY,
    K,
    Key,
    Kind,
    Section,
    choice,
    const,
    either,
    expression,
    integer,
    list_of,
    map_of,
    name,
    names,
    number,
    pair,
    quantity,
    section,
)
from mechsolve.joints.registry import KINDS
from mechsolve.joints.slider import GUIDE_LINE
from mechsolve.model.machine import INTEGRATORS

METHODS = ("auto", "newton", "split-newton")  # solver.method (and run --method)


# --- the mechanism file -------------------------------------------------------------

UNITS = Section(
    "units",
    "The units of plain numbers in the file (a number with a unit always means that unit).",
    {
        "length": K(TEXT, "Unit of plain lengths and coordinates: m, mm, cm, in..."),
        "angle": K(TEXT, "Unit of plain angles: deg or rad."),
    },
)

POINT = Section(
    "point",
    "A point placed by a length and an angle (from the link's first point along its base "
    "line, the line from its first to its second point, unless 'from' and 'ref' say).",
    {
        "length": K(
            LENGTH, "Distance from the 'from' point (default: the link's first point).", True
        ),  # fmt: skip
        "angle": K(ANGLE, "Angle from the reference line, counter-clockwise.", True),
        "from": K(name("point"), "The point the length is measured from."),
        "ref": K(names("point", 2), "The reference line [P, Q] (default: the base line)."),
    },
)

LINK = Section(
    "link",
    "A rigid link: its named points in its own frame and its mass properties.",
    {
        "points": K(
            map_of(either(XY, section("point")), "point"),
            "Its named points: [x, y] in the link's frame, or {length, angle} from another "
            "point. A point name shared by two links is the joint between them.",
            True,  # read_link checks it with its own message
        ),
        "mass": K(quantity("mass"), "Mass, e.g. 3500 kg (or give 'weight')."),
        "weight": K(quantity("force"), "Weight, e.g. 700 N: the mass is weight / g."),
        "com": K(either(name("point"), XY), "Centre of mass: a point name or [x, y]."),
        "inertia": K(quantity("moment of inertia"), "Moment of inertia about the centre of mass."),
        "uniform_bar": K(
            names("point", 2),
            "A uniform bar between two points: centre at the middle, J = m l^2 / 12.",
        ),
        "point_masses": K(
            map_of(quantity("mass"), "point"),
            "Masses concentrated at points, combined by the parallel-axis theorem.",
        ),
        "description": DESCRIPTION,
    },
)


def joint_section() -> Section:
    """The joint mapping: the keys of every registered kind (:mod:`mechsolve.joints.registry`),
    built when asked so that a kind registered later is read like the others."""
    return Section(
        "joint",
        "A joint: " + " or ".join(f"{c.kind} ({c.title})" for c in KINDS.values()) + ".",
        {
            **{c.kind: c.keys[c.kind] for c in KINDS.values()},
            "point": K(name("point"), "The joint's point (default: the joint's name)."),
            **{k: v for c in KINDS.values() for k, v in c.keys.items() if k != c.kind},
            "description": DESCRIPTION,
        },
        one_of=tuple(KINDS),
    )


JOINT = joint_section()
PIN = JOINT.only("revolute", "point", "description", title="pin")

LIMIT_START = Section(
    "limit start",
    "Start where a quantity is at its extreme over the turn.",
    {
        "limit": K(Kind("condition", doc="a quantity"), "The quantity, e.g. K.x.", True),
        "at": K(choice("min", "max"), "Its minimum or its maximum.", True),
    },
)

SEGMENT = Section(
    "segment",
    "One segment of a driver's motion: a duration and what the driver does in it.",
    {
        "accelerate": K(quantity("time"), "Accelerate for this long (to the speed 'to')."),
        "run": K(quantity("time"), "Run at constant speed for this long."),
        "decelerate": K(quantity("time"), "Decelerate for this long (to 'to', default 0)."),
        "dwell": K(quantity("time"), "Stand still for this long."),
        "to": K(quantity("speed"), "The speed reached at the end of the segment."),
    },
    one_of=("accelerate", "run", "decelerate", "dwell"),
)

TIME_POINT = pair(quantity("time"), quantity("angle"))

MOTION = Section(
    "motion",
    "A driver's motion law: constant acceleration, segments, a table of time and position, "
    "or an expression of t.",
    {
        "accelerate": K(quantity("angular acceleration"), "A constant acceleration (with 'from')."),
        "from": K(quantity("angular speed"), "The speed at t = 0 (default 0)."),
        "segments": K(list_of(section("segment"), 1), "Segments one after the other."),
        "table": K(
            list_of(TIME_POINT, 2), "[time, position] points, interpolated by a cubic spline."
        ),
        "end": K(choice("not-a-knot", "natural", "clamped"), "The spline's end conditions."),
        "law": K(expression("t"), "The position as an expression of t (SI: rad or m)."),
    },
    one_of=("accelerate", "segments", "table", "law"),
)

DRIVER = Section(
    "driver",
    "The input: a joint whose angle (or slider position) is prescribed.",
    {
        "joint": K(name("joint"), "The driven joint.", True),
        "speed": K(quantity("angular speed"), "Constant speed: 60 rpm, 1 rad/s (or m/s)."),
        "direction": K(
            choice("ccw", "cw", "counterclockwise", "clockwise", "forward", "backward"),
            "The sense of motion (forward or backward for a slider).",
        ),
        "start": K(
            either(ANGLE, section("limit start")),
            "The first position: an angle (a length for a slider) or {limit: K.x, at: max}.",
        ),
        "line": K(names("point", 2), "The line [P, Q] whose angle is the driver's angle."),
        "description": DESCRIPTION,
        "motion": K(section("motion"), "A motion law instead of a constant speed."),
    },
)

SWEEP = Section(
    "sweep",
    "The positions solved: the driver's travel and step (or a duration in time).",
    {
        "range": K(ANGLE, "The travel from the start, e.g. 360 deg."),
        "to": K(ANGLE, "The end position (instead of range)."),
        "step": K(ANGLE, "The step between positions, e.g. 5 deg."),
        "steps": K(integer(1), "The number of steps (instead of step)."),
        "duration": K(quantity("time"), "A travel in time at the driver's speed."),
        "time_step": K(quantity("time"), "A step in time."),
    },
)

ASSEMBLY = Section(
    "assembly",
    "Which way the mechanism is assembled: conditions, and an optional sketch.",
    {
        "conditions": K(
            either(list_of(CONDITION), CONDITION),
            "Conditions that pick the branch, e.g. 'B left of O3 -> A', 'C.x > B.x'.",
        ),
        "sketch": K(map_of(XY, "point"), "Approximate [x, y] of points at the start."),
    },
)

SHOWN = either(choice("all", "none"), NULL, names("point"), doc="'all', 'none' or a list of names")
OUTPUTS = Section(
    "outputs",
    "What the tables and plots show.",
    {
        "points": K(SHOWN, "Points tabulated: a list of names, all or none."),
        "links": K(SHOWN, "Links tabulated: a list of names, all or none."),
        "sliders": K(SHOWN, "Sliders tabulated: a list of names, all or none."),
        "quantities": K(
            list_of(choice("position", "velocity", "acceleration")),
            "Which of position, velocity, acceleration.",
        ),
        "relative": K(
            list_of(either(names("link", 2), TEXT)),
            "Relative angles of link pairs: [coupler, crank] or 'coupler/crank'.",
        ),
    },
)

SOLVER = Section(
    "solver",
    "Options of the position solver.",
    {
        "method": K(choice(*METHODS), "The method (default auto)."),
        "tolerance": K(number(0, 0.01), "The closure tolerance (relative, below 0.01)."),
        "max_iterations": K(integer(1, 1000), "Newton iterations per position (1..1000)."),
        "compiled": K(FLAG, "Newton sweeps through numba's compiled kernels (needs numba)."),
    },
)

GRAVITY = Section(
    "gravity",
    "Gravity with a direction.",
    {
        "g": K(quantity("acceleration"), "The magnitude, e.g. 9.81 m/s^2.", True),
        "direction": K(ANGLE, "Its direction (default -90 deg: downwards)."),
    },
)

LOAD_KINDS: dict[str, set[str]] = {
    "force": {"force", "direction", "at", "on", "frame"},
    "torque": {"torque", "on"},
    "spring": {"spring", "stiffness", "free_length", "on"},
    "damper": {"damper", "coefficient", "on"},
    "drag": {"drag", "coefficient", "on"},
}
LOAD = Section(  # the keys sorted, as the parser has always listed them
    "load",
    "A load: a force, torque, spring, damper or drag, acting while 'when' holds.",
    {
        "at": K(name("point"), "The point a force acts at."),
        "coefficient": K(quantity("damping"), "A damper's or drag's coefficient, e.g. 15 N s/m."),
        "damper": K(
            either(name("joint"), names("point", 2)),
            "A damper along a slider (its name) or between two points [P, Q].",
        ),
        "description": DESCRIPTION,
        "direction": K(ANGLE, "The direction of a force given as a magnitude."),
        "drag": K(name("point"), "A viscous drag at a point (against its velocity)."),
        "force": K(
            either(quantity("force"), pair(quantity("force"), quantity("force"))),
            "The force: [Fx, Fy] or a magnitude (with 'direction').",
        ),
        "frame": K(choice("global", "link"), "The frame of a force's components."),
        "free_length": K(LENGTH, "A spring's free length."),
        "on": K(
            either(name("link"), names("link", 2)),
            "The link the load acts on (for a spring or damper: the links at its two ends).",
        ),
        "spring": K(names("point", 2), "A spring between two points [P, Q]."),
        "stiffness": K(quantity("stiffness"), "A spring's stiffness, e.g. 2 kN/m."),
        "torque": K(quantity("torque"), "A torque on the link 'on', e.g. 50 N m."),
        "when": K(CONDITION, "The load acts only while this holds, e.g. 'K.vx < 0'."),
    },
    one_of=tuple(LOAD_KINDS),
    kinds=LOAD_KINDS,
)

MOTOR = Section(
    "motor",
    "The motor on the driver joint (mechsolve simulate): its torque against its speed.",
    {
        "joint": K(name("joint"), "The driver joint (the motor drives it)."),
        "stall": K(quantity("torque"), "Torque at rest of a linear characteristic."),
        "slope": K(
            quantity("rotational damping"), "Torque lost per unit speed: M = stall - slope*w."
        ),
        "table": K(
            list_of(pair(quantity("angular speed"), quantity("torque")), 2),
            "[speed, torque] points.",
        ),
        "torque": K(expression("omega", "t"), "The torque as an expression of omega and t."),
        "force": K(expression("v", "t"), "A linear motor's force as an expression of v and t."),
    },
    one_of=("stall", "table", "torque", "force"),
    needs={"stall": ("slope",)},
)

FLYWHEEL = Section(
    "flywheel",
    "A flywheel on a link.",
    {
        "on": K(name("link"), "The link carrying it.", True),
        "inertia": K(quantity("moment of inertia"), "Its moment of inertia.", True),
    },
)

FRACTION = either(number(0, 1), TEXT)
SIMULATE = Section(
    "simulate",
    "Forward dynamics under the motor (mechsolve simulate).",
    {
        "duration": K(quantity("time"), "Simulated time, e.g. 3 s.", True),
        "step": K(quantity("time"), "The output (and rk4) step."),
        "method": K(choice(*INTEGRATORS), "The integrator."),
        "rtol": K(FRACTION, "Relative tolerance of an adaptive integrator (0..1)."),
        "atol": K(FRACTION, "Absolute tolerance of an adaptive integrator (0..1)."),
        "from": K(either(const("rest"), quantity("angular speed")), "The start: rest or a speed."),
        "revolutions": K(quantity("dimensionless"), "Stop after this many revolutions."),
        "steady": K(FRACTION, "Stop when a revolution's mean speed changes less (e.g. 0.01 %)."),
        "formulation": K(
            choice("reduced", "multibody"),
            "reduced: the driver's one equation (one degree of freedom, one motor); "
            "multibody: the bodies' coordinates with the constraints (free motion too).",
        ),
        "tolerance": K(LENGTH, "multibody: the largest constraint violation allowed."),
        "pose": K(
            map_of(either(ANGLE, LENGTH), "joint"),
            "multibody: joint coordinates at the start, one per degree of freedom.",
        ),
        "rates": K(
            map_of(either(quantity("angular speed"), quantity("speed")), "joint"),
            "multibody: initial rates of joint coordinates, checked against the constraints.",
        ),
        "stop when": K(
            CONDITION,
            "multibody: end the run when this becomes true, e.g. 'bar.angle <= 0' (located "
            "to the integrator's tolerance).",
        ),
        "singular": K(
            choice("pass", "stop", "keep branch"),
            "multibody: at a singular position pass through it (default), stop there, or "
            "stop only where the motion would change a branch.",
        ),
    },
)

INSTANT = Section(
    "instant",
    "One driver state solved on its own: angle, speed and acceleration.",
    {
        "theta": K(ANGLE, "The driver angle.", True),
        "omega": K(quantity("angular speed"), "The driver's angular speed.", True),
        "alpha": K(quantity("angular acceleration"), "Its angular acceleration (default 0)."),
    },
)
INSTANT_LINEAR = Section(
    "linear instant",
    "One state of a slider driver: position, speed and acceleration.",
    {
        "s": K(LENGTH, "The driver position.", True),
        "v": K(quantity("speed"), "The driver's speed.", True),
        "a": K(quantity("acceleration"), "Its acceleration (default 0)."),
    },
)

# --- sections read by other modules (described for the schema) ------------------------

STUDY = Section(
    "study",
    "A design study (mechsolve sweep): parameters varied by key path.",
    {
        "design": K(
            choice("grid", "one-at-a-time", "oat", "random", "latin-hypercube", "lhs"),
            "How designs are chosen (default grid).",
        ),
        "samples": K(integer(1), "Designs of a random or Latin-hypercube study."),
        "seed": K(integer(0), "The random seed (the same designs every time)."),
        "parameters": K(
            map_of(ANY),
            "Key path -> values: 'links.crank.points.A[0]: 20..32 mm:7' or a list.",
        ),
        "figures": K(list_of(TEXT), "Extra figures of each design, e.g. range(K.y)."),
        "best": K(TEXT, "The best design: 'min EXPRESSION' or 'max EXPRESSION'."),
    },
)

CAM_LIFT = Section(
    "cam segment",
    "One segment of the cam's motion program: rise, return or dwell over a cam angle.",
    {
        "rise": K(ANGLE, "Rise over this cam angle."),
        "return": K(ANGLE, "Return over this cam angle."),
        "dwell": K(ANGLE, "Dwell over this cam angle."),
        "lift": K(LENGTH, "A translating follower's stroke."),
        "swing": K(ANGLE, "An oscillating follower's swing."),
        "law": K(TEXT, "The motion law, e.g. cycloidal, equal acceleration."),
    },
    one_of=("rise", "return", "dwell"),
)

FOLLOWER = Section(
    "follower",
    "The cam's follower.",
    {
        "type": K(TEXT, "translating or oscillating, knife-edge, roller or flat-faced.", True),
        "arm": K(LENGTH, "An oscillating follower's arm length l."),
        "roller_radius": K(LENGTH, "A roller follower's roller radius."),
        "offset": K(LENGTH, "A translating follower's offset e."),
        "face_offset": K(LENGTH, "An oscillating flat face's distance from its pivot."),
        "face_margin": K(LENGTH, "A flat face's clearance at each end of its width."),
    },
)

ALLOWANCE = Section(
    "allowable pressure angle",
    "Allowable pressure angles on the rise and the return.",
    {
        "rise": K(ANGLE, "On the rise, e.g. 30 deg."),
        "return": K(ANGLE, "On the return, e.g. 70 deg."),
    },
)

CAM = Section(
    "cam",
    "A cam design (mechsolve cam): follower, motion program, base size or allowances.",
    {
        "follower": K(section("follower"), "The follower.", True),
        "base_radius": K(LENGTH, "Base circle radius r0 (leave out to have it designed)."),
        "pivot_distance": K(LENGTH, "Cam centre to follower pivot a (oscillating)."),
        "start_angle": K(ANGLE, "The follower's start angle phi0 (oscillating)."),
        "rotation": K(TEXT, "The cam's sense: cw or ccw."),
        "speed": K(quantity("angular speed"), "The cam's speed, e.g. 60 rpm."),
        "motion": K(list_of(section("cam segment"), 1), "The segments over one turn.", True),
        "law": K(TEXT, "The motion law of every segment that names none."),
        "allowable_pressure_angle": K(
            either(ANGLE, section("allowable pressure angle")),
            "One angle, or {rise, return}.",
        ),
        "min_curvature_radius": K(LENGTH, "The least radius of curvature of the profile."),
        "table_step": K(ANGLE, "The step of the motion table (divides 360 deg)."),
    },
)

# --- the whole file -------------------------------------------------------------------

REQUIREMENT = Kind("text", doc="requirement")

TOP = Section(
    "mechanism file",
    "A planar mechanism for mechsolve: links with named points, joints, a driver, "
    "the sweep, loads and what to report.",
    {
        "name": K(TEXT, "The mechanism's name (titles of tables and plots)."),
        "description": K(either(TEXT, NULL), "Free text about the mechanism."),
        "units": K(section("units"), "Units of plain numbers: {length: mm, angle: deg}."),
        "ground": K(
            either(map_of(XY, "point"), NULL), "The ground's points: name -> [x, y] (global)."
        ),
        "links": K(map_of(section("link"), "link"), "The moving links: name -> its points."),
        "joints": K(
            map_of(either(names("link", least=2), section("joint")), "joint"),
            "The joints: name -> [link, link] (a pin at the point of that name), or "
            "{slider: [guide, block], point, line}.",
        ),
        "driver": K(section("driver"), "The input joint, its speed and start."),
        "sweep": K(either(section("sweep"), NULL), "The positions solved: range and step."),
        "assembly": K(
            either(list_of(CONDITION), section("assembly")),
            "Conditions that pick the branch, e.g. [B left of O3 -> A].",
        ),
        "outputs": K(section("outputs"), "What the tables and plots show."),
        "solver": K(section("solver"), "Options of the position solver."),
        "gravity": K(
            either(
                quantity("acceleration"),
                section("gravity"),
                choice("off", "none"),
                const(False),
                const(0),
            ),
            "Gravity downwards, e.g. 9.81 m/s^2; {g, direction}; or off.",
        ),  # fmt: skip
        "loads": K(map_of(section("load"), None), "The loads: name -> force, torque, spring..."),
        "variants": K(
            map_of(section("variant"), None),
            "Named overrides of parts of this file (null deletes a key); --variant NAME.",
        ),
        "instants": K(
            list_of(either(section("instant"), section("linear instant")), 1),
            "Driver states solved on their own: [{theta, omega, alpha}, ...].",
        ),
        "motor": K(section("motor"), "The motor (mechsolve simulate)."),
        "motors": K(
            map_of(section("motor")),
            "Several motors, each on its joint (mechsolve simulate's multibody path).",
        ),
        "flywheel": K(section("flywheel"), "A flywheel (mechsolve simulate, flywheel)."),
        "simulate": K(section("simulate"), "Forward dynamics (mechsolve simulate)."),
        "requirements": K(
            map_of(REQUIREMENT, None),
            "Checks of a run: name -> 'max(abs(input.torque)) <= 300 kN m' or 'full turn'.",
        ),
        "study": K(section("study"), "A design study (mechsolve sweep)."),
        "cam": K(section("cam"), "A cam design (mechsolve cam)."),
    },
)

# Every section by its id (the schema's definitions; ``section(id)`` refers to one).
SECTIONS: dict[str, Section] = {
    s.title: s
    for s in (
        UNITS, POINT, LINK, GUIDE_LINE, JOINT, JOINT_FRICTION, LIMIT_START, SEGMENT, MOTION,
        DRIVER, SWEEP, ASSEMBLY, OUTPUTS, SOLVER, GRAVITY, LOAD, MOTOR, FLYWHEEL, SIMULATE, INSTANT,
        INSTANT_LINEAR, STUDY, CAM_LIFT, FOLLOWER, ALLOWANCE, CAM, TOP,
    )
}  # fmt: skip

# --- the torque problem (mechsolve flywheel FILE without links; not in the schema) ----

TORQUE_PROBLEM = Section(
    "torque problem",
    "A flywheel problem stated by its torque curve.",
    {
        "name": K(TEXT, "The problem's name."),
        "description": K(TEXT, "Free text."),
        "units": K(section("units"), "Units of plain numbers."),
        "torque": K(section("torque curve"), "The driving torque over a cycle.", True),
        "resisting": K(either(const("mean"), quantity("torque")), "mean or a torque."),
        "speed": K(quantity("angular speed"), "The mean speed.", True),
        "delta": K(either(number(0, 1), TEXT), "The coefficient of fluctuation, e.g. 1/80."),
    },
)
TORQUE_CURVE = Section(
    "torque curve",
    "The torque: a table of [angle, torque] points or a law of angle.",
    {
        "table": K(list_of(pair(ANGLE, quantity("torque")), 3), "[angle, torque] points."),
        "law": K(expression("angle"), "The torque as an expression of angle (rad)."),
        "cycle": K(ANGLE, "The cycle (default 360 deg)."),
    },
)
