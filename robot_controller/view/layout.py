"""What the view shows and where: entity paths, colours, series styles, and the blueprint (the arm in 3-D on the left,
time series on the right), for the live view and the one from a bag. With several joints the plots are in tabs: "all
joints" (error, position and torque of every joint, a colour per joint), then one per joint. A run with a camera has its
image with the markers found (``DETECTIONS``) under the arm."""

from __future__ import annotations

import numpy as np

from robot_controller.blocks import spec
from robot_controller.scoring.plots import TRACES, quantity
from robot_controller.view.arm import Arm, entity_part

APPLICATION_ID = "robot_controller"
TIMELINE = "time"  #: seconds since the controller's first tick
LIVE_WINDOW_S = 10.0  #: the plots of the live view scroll over this many seconds

WORLD = "world"
ARM = f"{WORLD}/arm"
POSES = {  # pose → (colour RGBA, radius factor), in instance order: the true arm solid, the others ghosts
    "true": ([235, 125, 25, 255], 1.0),
    "measured": ([60, 140, 255, 80], 1.6),
    "reference": ([40, 190, 90, 80], 2.2),
}
POSITION, ERROR, TORQUE, TIMING = "plots/position", "plots/error", "plots/torque", "plots/timing"
STATUS_LOG = "log/status"
DETECTIONS = "camera/detections"  #: the camera's image with the markers found outlined (spec.DETECTIONS)

# series → (view, label, colour, width); the labels are tracking.png's (``{q}``: angle, or position on a chain
# with a slide). "measured" is the sensor's readings, "error_controller" the controller's own error.
SERIES = {
    "reference": (POSITION, TRACES["reference"], [40, 190, 90], 2.0),
    "true": (POSITION, TRACES["true"], [235, 125, 25], 2.0),
    "measured": (POSITION, TRACES["readings"], [60, 140, 255], 1.0),
    "planned": (POSITION, f"planned ({spec.REFERENCE.topic} samples)", [150, 150, 150], 1.0),
    "error_true": (ERROR, TRACES["error_true"], [220, 50, 50], 1.5),
    "error_controller": (ERROR, TRACES["error_estimate"], [120, 120, 200], 1.0),
    "commanded": (TORQUE, TRACES["commanded"], [150, 80, 200], 1.5),
    "applied": (TORQUE, TRACES["applied"], [235, 125, 25], 1.5),
    "jitter": (TIMING, "tick jitter |period − nominal|", [110, 110, 110], 1.0),
    "jitter_p99": (TIMING, f"jitter p99 (last s, {spec.DIAGNOSTICS.topic})", [220, 50, 50], 2.0),
    "latency": (TIMING, "reading → motor latency", [60, 140, 255], 1.0),
}
PER_JOINT = {"reference", "true", "measured", "planned", "error_true", "error_controller", "commanded", "applied"}
# The "all joints" tab: (view, series, title, unit on a revolute joint, on a prismatic one), each in its joint's
# colour, named in the first plot's legend.
OVERVIEW = (
    (ERROR, "error_true", "tracking error, reference − true {q}", "mrad", "mm"),
    (POSITION, "true", "position, true {q}", "rad", "m"),
    (TORQUE, "commanded", "torque, commanded", "N·m", "N"),
)
# A joint's own tab: (view, title) on a revolute joint ("rad") and on a prismatic one ("m").
PANELS = {
    "rad": ((POSITION, "position [rad]"), (ERROR, "tracking error [mrad]"), (TORQUE, "torque [N·m]")),
    "m": ((POSITION, "position [m]"), (ERROR, "tracking error [mm]"), (TORQUE, "force [N]")),
}
# A colour per joint in the "all joints" tab (matplotlib's tab10), repeated past ten joints.
JOINT_COLOURS = [
    list(bytes.fromhex(h)) for h in "1f77b4 ff7f0e 2ca02c d62728 9467bd 8c564b e377c2 7f7f7f bcbd22 17becf".split()
]


def series_path(series: str, joint: str, joint_count: int) -> str:
    view = SERIES[series][0]
    if series not in PER_JOINT or joint_count == 1:
        return f"{view}/{series}"
    return f"{view}/{entity_part(joint)}/{series}"


def series_label(series: str, units: list[str]) -> str:
    """The name of ``series`` on joints in ``units`` (rad, or m on a slide), as tracking.png names it."""
    return SERIES[series][1].format(q=quantity(units))


def log_styles(rec, joint_names: list[str], units: list[str] | None = None) -> None:
    """Names, colours and widths of every series (static); ``units``: each joint's (default rad)."""
    import rerun as rr

    n = len(joint_names)
    units = units or ["rad"] * n
    for series, (_, _, colour, width) in SERIES.items():
        joints = joint_names if series in PER_JOINT else joint_names[:1]
        label = series_label(series, units)
        for joint in joints:
            name = label if series not in PER_JOINT or n == 1 else f"{label} ({joint})"
            style = rr.SeriesLines(colors=[colour], widths=[width], names=[name])
            rec.log(series_path(series, joint, n), style, static=True)


def log_scene(rec, arm: Arm) -> None:
    """The static 3-D scene: axes convention, a pedestal up to the first joint, the arm's shapes (one per pose)."""
    import rerun as rr

    rec.log(WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    x, y, z = arm.base_xyz
    if z > 0.05:  # the arm's first joint stands on something: draw it
        shape = {"lengths": [z - 0.04], "radii": [0.03], "colors": [[95, 95, 105]], "fill_mode": "solid"}
        rec.log(f"{WORLD}/pedestal", rr.Cylinders3D(centers=[[x, y, 0.5 * z - 0.02]], **shape), static=True)
    arm.log_static(rec, ARM, list(POSES.values()))


def blueprint(arm: Arm, *, live: bool, camera: bool = False):
    """The saved layout: 3-D view left, time series right (position, tracking error, torque, timing). Live, the plots
    scroll over the last ``LIVE_WINDOW_S``; built from a bag, they show the whole run. ``camera``: the camera's image
    with its detections under the 3-D view."""
    import rerun.blueprint as rrb

    # From the front (−y: the reference arm moves in the x-z plane), a little above and aside, the whole sweep in view.
    target, radius = arm.sphere
    direction = np.array([0.35, -1.0, 0.3])
    distance = max(0.8, 3.2 * radius)  # the sphere across the 3-D view's narrow width
    eye = rrb.EyeControls3D(
        position=(target + direction / np.linalg.norm(direction) * distance).tolist(),
        look_target=target.tolist(),
        eye_up=[0.0, 0.0, 1.0],
    )
    ranges = None
    if live:
        ranges = rrb.VisibleTimeRange(
            TIMELINE,
            start=rrb.TimeRangeBoundary.cursor_relative(seconds=-LIVE_WINDOW_S),
            end=rrb.TimeRangeBoundary.cursor_relative(),
        )

    def plot(origin: str, name: str, **more):
        more.setdefault("plot_legend", rrb.PlotLegend(corner="LeftTop"))
        return rrb.TimeSeriesView(origin=origin, name=name, time_ranges=ranges, **more)

    joints = arm.joint_names
    slides = [joint for joint, unit in zip(joints, arm.units, strict=True) if unit == "m"]  # in m, mm and N
    what = quantity(arm.units)
    panels = {joint: PANELS["m" if joint in slides else "rad"] for joint in joints}

    def overview(k: int, title: str, revolute: str, prismatic: str) -> str:
        units = revolute + (f"; {prismatic} on {', '.join(slides)}" if slides else "")
        return f"{title.format(q=what)} [{units}]" + (" (colours as above)" if k else "")

    if len(joints) == 1:
        plots = rrb.Vertical(*(plot(*panel) for panel in panels[joints[0]]), plot(TIMING, "loop timing [ms]"))
    else:
        plots = rrb.Vertical(
            rrb.Tabs(
                rrb.Vertical(
                    *(
                        overview_plot(plot, view, series, overview(k, *titles), joints, legend=k == 0)
                        for k, (view, series, *titles) in enumerate(OVERVIEW)
                    ),
                    row_shares=[3, 2, 2],  # the first holds the legend: a line per joint
                    name="all joints",
                ),
                *(
                    rrb.Vertical(
                        *(plot(f"{view}/{entity_part(joint)}", f"{joint}: {title}") for view, title in panels[joint]),
                        name=joint,
                    )
                    for joint in joints
                ),
                active_tab=0,
                name="plots",
            ),
            plot(TIMING, "loop timing [ms]"),
            row_shares=[4, 1],
        )
    arm_name = "arm: true (solid), sensor reading (blue), reference (green)"
    arm_view = rrb.Spatial3DView(origin=WORLD, name=arm_name, eye_controls=eye)
    if camera:
        image_view = rrb.Spatial2DView(origin=DETECTIONS, name=f"camera: markers found ({spec.DETECTIONS.topic})")
        arm_view = rrb.Vertical(arm_view, image_view, row_shares=[3, 2])
    return rrb.Blueprint(
        rrb.Horizontal(arm_view, plots, column_shares=[2, 3]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline=TIMELINE),
    )


def overview_plot(plot, view: str, series: str, title: str, joints: list[str], *, legend: bool):
    """One series of every joint in one plot (``plot`` makes the view), each in its joint's colour and named by the
    joint: the view's overrides, so the series keep their own style in their joint's tab."""
    import rerun as rr
    import rerun.blueprint as rrb

    paths = [series_path(series, joint, len(joints)) for joint in joints]
    width = SERIES[series][3]
    colours = [JOINT_COLOURS[k % len(JOINT_COLOURS)] for k in range(len(joints))]
    return plot(
        view,
        title,
        plot_legend=rrb.PlotLegend(corner="LeftTop", visible=legend),
        contents=[f"+ {path}" for path in paths],
        overrides={
            path: rr.SeriesLines(colors=[colour], widths=[width], names=[joint]).visualizer()
            for path, joint, colour in zip(paths, joints, colours, strict=True)
        },
    )
