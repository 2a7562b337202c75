"""The layout the viewer opens on: the 3-D scene (robots and ground) with the plots beside it.

Plots are grouped so a 22-joint robot reads well: one plot per limb group (``scene.joint_groups``), a tab
per quantity (positions, velocities, efforts, commanded vs actual, balance), and only the open tab is drawn,
which also keeps a software-rendered browser fast. Each plot shows the last ``PLOT_SECONDS`` up to the time
cursor plus ``LEGEND_SECONDS`` of empty "future" on the right, where the legend sits: it never covers data.
The time panel follows the newest data (``play_state="following"``), so a viewer opened late shows the
present, not the start.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import rerun.blueprint as rrb

from .scene import SIM_TIMELINE

PLOT_SECONDS = 8.0  # history shown in a plot, up to the time cursor
LEGEND_SECONDS = 3.5  # empty time right of the cursor, under the legend


@dataclass
class RobotLayout:
    """What the blueprint needs to know about one robot's plots."""

    groups: Sequence[str] = ()  # joint_states plot groups (entity parts)
    controllers: Mapping[str, Sequence[str]] = field(default_factory=dict)  # controller -> its plot groups
    has_balance: bool = False

    def key(self) -> tuple:
        return (tuple(self.groups), tuple((c, tuple(g)) for c, g in sorted(self.controllers.items())),
                self.has_balance)


def title(group: str) -> str:
    return group.replace("_", " ")


def time_series(name: str, origin: str, timeline: str) -> rrb.TimeSeriesView:
    return rrb.TimeSeriesView(
        name=name, origin=origin,
        # Only the recent past is queried and drawn (cheap at any run length) ...
        time_ranges=rrb.VisibleTimeRange(
            timeline, start=rrb.TimeRangeBoundary.cursor_relative(seconds=-PLOT_SECONDS),
            end=rrb.TimeRangeBoundary.cursor_relative(seconds=0)),
        # ... and the x axis runs a little past the cursor, where the legend sits.
        axis_x=rrb.TimeAxis(view_range=rrb.TimeRange(
            start=rrb.TimeRangeBoundary.cursor_relative(seconds=-PLOT_SECONDS),
            end=rrb.TimeRangeBoundary.cursor_relative(seconds=LEGEND_SECONDS))),
        plot_legend=rrb.PlotLegend(corner="RightTop", visible=True),
    )


def grid(views: list[rrb.View], name: str) -> rrb.Container:
    if len(views) == 1:
        return rrb.Vertical(*views, name=name)
    return rrb.Grid(*views, grid_columns=2 if len(views) > 2 else 1, name=name)


def robot_plots(namespace: str, layout: RobotLayout, timeline: str = SIM_TIMELINE,
                with_namespace: bool = False) -> rrb.Container:
    """One robot's plots: a tab per quantity, a plot per limb group."""
    plots = f"plots/{namespace}"
    prefix = f"{namespace}: " if with_namespace else ""
    tabs: list[rrb.Container] = []
    groups = list(layout.groups)
    for quantity, label in (("position", "positions"), ("velocity", "velocities"), ("effort", "efforts")):
        if groups:
            views = [time_series(f"{prefix}{title(g)} {quantity} ", f"{plots}/joint_states/{quantity}/{g}",
                                 timeline) for g in groups]
        else:  # nothing received yet: everything under the quantity, grouped or not
            views = [time_series(f"{prefix}{label}", f"{plots}/joint_states/{quantity}", timeline)]
        tabs.append(grid(views, label))
    for controller, controller_groups in layout.controllers.items():
        views = [time_series(f"{prefix}{controller}: {title(g)} commanded vs actual", f"{plots}/{controller}/{g}",
                             timeline) for g in controller_groups]
        if views:
            tabs.append(grid(views, f"{controller}"))
    if layout.has_balance:
        tabs.append(rrb.Vertical(time_series(f"{prefix}CoM, ZMP (m), balanced (1/0)", f"{plots}/balance", timeline),
                                 name="balance"))
    return rrb.Tabs(*tabs, active_tab=0, name=namespace)


def build_blueprint(robots: Mapping[str, RobotLayout] | None = None, timeline: str = SIM_TIMELINE) -> rrb.Blueprint:
    """``robots``: namespace -> its plot layout; ``timeline``: the one the time panel follows."""
    robots = robots or {}
    scene = rrb.Spatial3DView(
        name="scene", origin="world",
        line_grid=rrb.LineGrid3D(visible=False),  # we log our own ground with a 0.5 m grid
        # A three-quarter view from the front left of a standing humanoid, like RViz's default orbit.
        eye_controls=rrb.EyeControls3D(position=[1.9, 1.4, 1.3], look_target=[0.0, 0.0, 0.55],
                                       eye_up=[0.0, 0.0, 1.0]),
    )
    side: rrb.Container | rrb.View
    several = len(robots) > 1
    tabs = [robot_plots(ns, layout, timeline, with_namespace=several) for ns, layout in robots.items()]
    if len(tabs) == 1:
        side = tabs[0]
    elif tabs:
        side = rrb.Tabs(*tabs)
    else:
        side = time_series("plots", "plots", timeline)
    return rrb.Blueprint(
        rrb.Horizontal(scene, side, column_shares=[11, 9]),
        # "following": the cursor stays on the newest data, also in a viewer opened late.
        rrb.TimePanel(timeline=timeline, state="collapsed", play_state="following"),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        collapse_panels=False,
    )
