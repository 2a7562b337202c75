"""The layout the viewer opens on: the 3-D scene (robots and ground) with the plots beside it.

Plots are grouped so a 22-joint robot reads well: one plot per limb group (``scene.joint_groups``), a tab
per quantity (positions, velocities, efforts, commanded vs actual, balance), and only the open tab is drawn,
which also keeps a software-rendered browser fast. All of a robot's plots read columns of one entity (see
``scene.py``): each plot maps the time series' scalars to its own column (``position:left_leg``) and names
its series here, so a 22-joint robot costs the viewer no more chunks than a one-joint one. Each plot shows
the last ``PLOT_SECONDS`` up to the time cursor, the newest on the right as in rqt_plot, after
``LEGEND_SECONDS`` of empty axis on the left where the legend sits (the default corner): it never covers data.
The time panel follows the newest data (``play_state="following"``), so a viewer opened late shows the
present, not the start.

The sensors get two tabs: "imu" (angular velocity and linear acceleration of each IMU, columns of the robot
entity like the joints) and "camera" (each camera's image and depth image in 2-D views: both are rows of
the camera's one entity, and each view activates only its visualizer, as the 3-D view does for the frustum and
the image, so the depth image is not also lifted into points there). The 3-D view starts
where the world file's ``<gui><camera><pose>`` puts Gazebo's camera, when it has one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import rerun as rr
import rerun.blueprint as rrb
from rerun.blueprint.encodings import ComponentSourceKind, VisualizerComponentMapping

from .scene import BALANCE_SERIES, PALETTE, SIM_TIMELINE, PlotGroup, lighter, robot_entity, series_component
from .sensors import IMU_SERIES

# The side panel's tabs, in this order (the viewer's ``plots`` parameter picks some).
PLOT_TABS = ("positions", "velocities", "efforts", "commanded", "balance", "imu", "camera")
QUANTITY_TABS = {"positions": "position", "velocities": "velocity", "efforts": "effort"}
PLOT_SECONDS = 8.0  # history shown in a plot, up to the time cursor
LEGEND_SECONDS = 4.0  # empty time before that history, under the legend (Rerun 0.41's default corner: bottom left)
CURSOR_MARGIN = 0.3  # s of axis past the cursor, so the newest point is not on the plot's edge
# Without a world camera: a three-quarter view from the front left of a standing humanoid, like RViz's orbit.
DEFAULT_EYE, DEFAULT_TARGET = [1.9, 1.4, 1.3], [0.0, 0.0, 0.55]


@dataclass
class RobotLayout:
    """What the blueprint needs to know about one robot's plots."""

    groups: Sequence[PlotGroup] = ()  # joint_states plot groups
    controllers: Mapping[str, Sequence[PlotGroup]] = field(default_factory=dict)  # controller -> its plot groups
    has_balance: bool = False
    imus: Sequence[tuple[str, str]] = ()  # (column part, label) per IMU
    cameras: Sequence[tuple[str, bool]] = ()  # (camera entity, has a depth image) per camera

    def key(self) -> tuple:
        return (tuple(self.groups), tuple((c, tuple(g)) for c, g in sorted(self.controllers.items())),
                self.has_balance, tuple(self.imus), tuple(self.cameras))


def image_visualizers() -> list:
    """A camera's colour image: always JPEG (``color_image`` gives u8 RGB or L, which Rerun compresses). Only
    visualizers with data on the entity: one without (a raw Image's) marks the view with an error. Fresh each
    time: a visualizer's id names it in the layout."""
    return [rr.EncodedImage.from_fields().visualizer()]


def title(group: str) -> str:
    return group.replace("_", " ")


def series(entity: str, component: str, names: Sequence[str], colors: Sequence[Sequence[int]],
           widths: Sequence[float] | None = None) -> dict:
    """A view's overrides: the time series of ``entity`` read from ``component``, with these legend names."""
    return {entity: [rr.SeriesLines(names=list(names), colors=[list(c) for c in colors], widths=widths).visualizer(
        mappings=[VisualizerComponentMapping(target="Scalars:scalars", source_kind=ComponentSourceKind.SourceComponent,
                                             source_component=component)])]}


def joint_series(entity: str, kind: str, group: PlotGroup) -> dict:
    return series(entity, series_component(kind, group.part), group.labels, PALETTE[:len(group.labels)])


def controller_series(entity: str, controller: str, group: PlotGroup) -> dict:
    """A light thin "<joint> ref" line (the reference) and a solid one (the measurement) per joint."""
    colors = [c for color in PALETTE[:len(group.labels)] for c in (lighter(color), color)]
    names = [name for label in group.labels for name in (f"{label} ref", label)]
    return series(entity, series_component(controller, group.part), names, colors, [1.0, 2.0] * len(group.labels))


def time_series(name: str, origin: str, timeline: str, overrides: dict | None = None) -> rrb.TimeSeriesView:
    return rrb.TimeSeriesView(
        name=name, origin=origin, overrides=overrides,
        # Only the recent past is queried and drawn (cheap at any run length) ...
        time_ranges=rrb.VisibleTimeRange(
            timeline, start=rrb.TimeRangeBoundary.cursor_relative(seconds=-PLOT_SECONDS),
            end=rrb.TimeRangeBoundary.cursor_relative(seconds=0)),
        # ... and the x axis starts earlier, leaving empty room on the left where the legend sits (the
        # default corner: no legend property to send, a chunk less per plot for every viewer).
        axis_x=rrb.TimeAxis(view_range=rrb.TimeRange(
            start=rrb.TimeRangeBoundary.cursor_relative(seconds=-PLOT_SECONDS - LEGEND_SECONDS),
            end=rrb.TimeRangeBoundary.cursor_relative(seconds=CURSOR_MARGIN))),
    )


def grid(views: list[rrb.View], name: str) -> rrb.Container:
    if len(views) == 1:
        return rrb.Vertical(*views, name=name)
    return rrb.Grid(*views, grid_columns=2 if len(views) > 2 else 1, name=name)


def robot_plots(namespace: str, layout: RobotLayout, timeline: str = SIM_TIMELINE,
                with_namespace: bool = False, plots: Sequence[str] = PLOT_TABS) -> rrb.Container:
    """One robot's plots: a tab per quantity, a plot per limb group (the tabs named in ``plots``)."""
    entity = robot_entity(namespace)
    prefix = f"{namespace}: " if with_namespace else ""
    tabs: list[rrb.Container] = []
    groups = list(layout.groups)
    for label, quantity in QUANTITY_TABS.items():
        if label not in plots:
            continue
        if groups:
            views = [time_series(f"{prefix}{title(g.part)} {quantity} ", entity, timeline,
                                 joint_series(entity, quantity, g)) for g in groups]
        else:  # nothing received yet: an empty plot until the joints are known
            views = [time_series(f"{prefix}{label}", entity, timeline)]
        tabs.append(grid(views, label))
    for controller, controller_groups in layout.controllers.items() if "commanded" in plots else ():
        views = [time_series(f"{prefix}{controller}: {title(g.part)} commanded vs actual", entity, timeline,
                             controller_series(entity, controller, g)) for g in controller_groups]
        if views:
            tabs.append(grid(views, f"{controller}"))
    if layout.has_balance and "balance" in plots:
        tabs.append(rrb.Vertical(time_series(f"{prefix}CoM, ZMP (m), balanced (1/0)", entity, timeline,
                                             series(entity, "balance:values", BALANCE_SERIES, PALETTE[:6])),
                                 name="balance"))
    if layout.imus and "imu" in plots:
        views = [time_series(f"{prefix}{label}: {what}", entity, timeline,
                             series(entity, f"{kind}:{part}", IMU_SERIES, PALETTE[:3]))
                 for part, label in layout.imus
                 for kind, what in (("angular_velocity", "angular velocity (rad/s)"),
                                    ("linear_acceleration", "linear acceleration (m/s²)"))]
        tabs.append(grid(views, "imu"))
    if layout.cameras and "camera" in plots:
        views = []
        for camera, depth in layout.cameras:
            label = camera.rsplit("/", 1)[-1]
            views.append(rrb.Spatial2DView(name=f"{prefix}{label}", origin=camera, overrides={camera: image_visualizers()}))
            if depth:
                views.append(rrb.Spatial2DView(name=f"{prefix}{label} depth", origin=camera,
                                               overrides={camera: [rr.DepthImage.from_fields().visualizer()]}))
        tabs.append(grid(views, "camera"))
    return rrb.Tabs(*tabs, active_tab=0, name=namespace)


def build_blueprint(robots: Mapping[str, RobotLayout] | None = None, timeline: str = SIM_TIMELINE,
                    ground: bool = True, plots: Sequence[str] = PLOT_TABS,
                    eye: tuple[Sequence[float], Sequence[float]] | None = None,
                    depth_cloud: bool = False) -> rrb.Blueprint:
    """``robots``: namespace -> its plot layout; ``timeline``: the one the time panel follows; ``ground``: draw
    the ground grid; ``plots``: the tabs beside the 3-D scene (of ``PLOT_TABS``; none: the scene alone);
    ``eye``: (position, look target) of the 3-D view's camera (the world's GUI camera), else the default;
    ``depth_cloud``: the depth images lifted into points in the 3-D view too (RViz's DepthCloud: 76,800 points
    for a 320 x 240 camera, which slowed a software-rendered page to a frame every 2 s; else only in the
    camera tab)."""
    robots = robots or {}
    # Each camera's frustum and image; its depth image too with depth_cloud (the default set of visualizers).
    frusta = {} if depth_cloud else {camera: [rr.Pinhole.from_fields().visualizer(), *image_visualizers()]
                                     for layout in robots.values() for camera, _ in layout.cameras}
    position, target = eye if eye is not None else (DEFAULT_EYE, DEFAULT_TARGET)
    scene = rrb.Spatial3DView(
        name="scene", origin="world", overrides=frusta or None,
        # The ground: the viewer's own grid (0.5 m, z = 0), like RViz's Grid display. It is part of the
        # layout, not of the data, so the web server never drops it from a short history.
        line_grid=rrb.LineGrid3D(visible=ground, spacing=0.5, plane=rr.components.Plane3D.XY,
                                 color=[150, 155, 160, 255], stroke_width=1.5),
        eye_controls=rrb.EyeControls3D(position=list(position), look_target=list(target), eye_up=[0.0, 0.0, 1.0]),
    )
    side: rrb.Container | rrb.View | None
    several = len(robots) > 1
    tabs = [robot_plots(ns, layout, timeline, several, plots) for ns, layout in robots.items()] if plots else []
    if len(tabs) == 1:
        side = tabs[0]
    elif tabs:
        side = rrb.Tabs(*tabs)
    elif plots:  # no robot yet
        side = time_series("plots", "plots", timeline)
    else:  # no plots asked for: the 3-D scene alone
        side = None
    return rrb.Blueprint(
        rrb.Horizontal(scene, side, column_shares=[11, 9]) if side is not None else scene,
        # "following": the cursor stays on the newest data, also in a viewer opened late.
        rrb.TimePanel(timeline=timeline, state="collapsed", play_state="following"),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        collapse_panels=False,
    )
