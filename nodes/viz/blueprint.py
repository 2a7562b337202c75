"""The layout the viewer opens on: the 3-D scene (robots and ground) with the plots beside it."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import rerun.blueprint as rrb


def robot_plots(namespace: str, controllers: Sequence[str], has_balance: bool) -> rrb.Container:
    """One tab per robot: joint positions / velocities / efforts, commanded vs actual, balance."""
    plots = f"plots/{namespace}"
    views: list = [
        rrb.TimeSeriesView(name=f"{namespace}: joint positions", origin=f"{plots}/joint_states/position"),
        rrb.TimeSeriesView(name=f"{namespace}: joint velocities", origin=f"{plots}/joint_states/velocity"),
        rrb.TimeSeriesView(name=f"{namespace}: joint efforts", origin=f"{plots}/joint_states/effort"),
    ]
    for controller in controllers:
        views.append(rrb.TimeSeriesView(name=f"{namespace}/{controller}: commanded vs actual",
                                        origin=f"{plots}/{controller}"))
    if has_balance:
        views.append(rrb.TimeSeriesView(name=f"{namespace}: CoM, ZMP, balanced", origin=f"{plots}/balance"))
    return rrb.Vertical(*views, name=namespace)


def build_blueprint(robots: Mapping[str, tuple[Sequence[str], bool]] | None = None) -> rrb.Blueprint:
    """``robots``: namespace -> (trajectory controllers seen, has humanoid_state)."""
    robots = robots or {}
    scene = rrb.Spatial3DView(
        name="scene", origin="world",
        line_grid=rrb.LineGrid3D(visible=False),  # we log our own ground with a 0.5 m grid
        # A three-quarter view from the front left of a standing humanoid, like RViz's default orbit.
        eye_controls=rrb.EyeControls3D(position=[1.9, 1.4, 1.3], look_target=[0.0, 0.0, 0.55],
                                       eye_up=[0.0, 0.0, 1.0]),
    )
    side: rrb.Container | rrb.View
    tabs = [robot_plots(ns, controllers, balance) for ns, (controllers, balance) in robots.items()]
    if len(tabs) == 1:
        side = tabs[0]
    elif tabs:
        side = rrb.Tabs(*tabs)
    else:
        side = rrb.TimeSeriesView(name="plots", origin="plots")
    return rrb.Blueprint(
        rrb.Horizontal(scene, side, column_shares=[3, 2]),
        rrb.TimePanel(timeline="sim_time", state="collapsed"),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )
