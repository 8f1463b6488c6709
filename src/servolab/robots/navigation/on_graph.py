"""``servolab navigate --map``: navigate a robot that runs elsewhere on the graph, as Nav2 runs
beside a TurtleBot3 -- a map from map_server, the robot's pose from its odometry, and the
navigator driving it through its ``cmd_vel``.

``servolab navigate`` alone simulates seed 000's whole floor in one process. A lab's fleet is
the other way round: each robot runs its own bringup (``servolab control run
turtlebot3_waffle --namespace /robot1``, or a real TurtleBot3), and navigation runs where the
lab puts it, reaching the robot through a router (docs/fleets.md). This run makes, in one
process and in the robot's namespace:

- a map server: the map.yaml (map_server's format, :func:`~servolab.vision.map_file.load_map`)
  on ``map``, latched, in the ``map`` frame;
- a localiser from odometry alone: the robot's ``odom`` (``nav_msgs/msg/Odometry``) composed
  with its known start in the map, ``initial_pose`` (as AMCL's initial pose sets ``map ->
  odom`` and nothing corrects it after), on ``fused_pose``;
- the navigator (:class:`~.navigator.NavigatorNode`: D* Lite on the inflated map and DWA),
  whose ``cmd_vel`` goes where the robot listens: ``cmd_vel`` and ``odom`` name the robot's
  topics (TurtleBot3's bringup: ``cmd_vel``, ``odom``; servolab's Waffle under ros2_control:
  ``diff_drive_controller/cmd_vel`` and ``diff_drive_controller/odom``), and the command's type
  is the one the robot's subscriber has on the graph (``Twist``, or ``TwistStamped`` for
  jazzy's diff_drive_controller), found before anything moves.

**A partition** (the router gone) is seen as odometry that stops coming: the navigator's pose
goes stale and it stops commanding (the robot's own ``cmd_vel`` watchdog has stopped the wheels
by then), and drives on to the goal when odometry comes back, within move_base's
``controller_patience``. The run counts each **outage** (odometry silent for longer than
:data:`OUTAGE_S`), how long it lasted and how many odometry messages were lost across it (from
the stamps on either side and the odometry's own period), and writes them to
``summary.json``, beside the bag (``navigate_bag/``: what this process received, nothing of it
lost) and ``navigate.png`` (the map, the plans and the path, outages marked).

Time is the wall clock: the robot is real, or emulated in real time.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ...harness import interruption
from ...middleware.names import in_namespace, node_namespace, validate_topic_name
from ...planning.dwa import DwaConfig
from ...vision.map_file import OccupancyMap, load_map
from ..lifecycle import Step, Task, run_task
from .navigator import (
    ODOMETRY,
    POSE,
    TWIST,
    TWIST_STAMPED,
    NavigationStatus,
    NavigatorNode,
    Patience,
)
from .params import CostmapParams, MoveBaseParams, load_planning
from .session import GoalNotReached, NavigationError
from .tracker_node import LATCHED, MAP_FRAME, OCCUPANCY_GRID

if TYPE_CHECKING:
    from ...middleware.context import Context
    from ...middleware.transport import TransportOptions
    from ...runs import RunFolder

Say = Callable[[str], None]
#: s without odometry that count as an outage (the navigator's pose timeout: from then on it
#: stops commanding)
OUTAGE_S = 0.5
#: s the run waits for the robot to appear on the graph (its cmd_vel subscriber) and for its
#: first odometry
START_TIMEOUT_S = 30.0
#: what the bag records (relative: the robot's own in its namespace) besides the robot's
#: command and odometry topics
RECORDED = ("map", "fused_pose", "plan", "goal_pose", "local_plan", "path",
            "global_costmap/costmap", "navigate_to_pose/_action/status")


@dataclass(frozen=True)
class GraphNavigation:
    """A navigation of a robot on the graph, read and checked (:func:`prepare`)."""

    map: OccupancyMap
    initial_pose: tuple[float, float, float]
    goal: tuple[float, float, float]
    costmap: CostmapParams
    dwa: DwaConfig
    move_base: MoveBaseParams
    transport: TransportOptions
    namespace: str = "/"
    cmd_vel: str = "cmd_vel"
    odom: str = "odom"
    ignored: tuple[str, ...] = ()

    def topic(self, name: str) -> str:
        """``name`` as the robot has it: ``/robot1/cmd_vel``."""
        return in_namespace(name if name.startswith("/") else f"/{name}", self.namespace)


def _on_free_cell(m: OccupancyMap, what: str, x: float, y: float) -> None:
    cell = m.cell_of(x, y)
    if cell is None:
        x0, x1, y0, y1 = m.extent
        raise NavigationError(f"{what} ({x:g}, {y:g}) is off the map {m.path} (x {x0:g}..{x1:g}"
                              f", y {y0:g}..{y1:g} m)")
    lethal, unknown = m.lethal_and_unknown()
    col, row = cell
    if lethal[row, col] or unknown[row, col]:
        raise NavigationError(f"{what} ({x:g}, {y:g}) is on an occupied or unknown cell of "
                              f"{m.path}")


def prepare(map_file: str | Path, initial_pose: tuple[float, float, float],
            goal: tuple[float, float], transport: TransportOptions, *,
            goal_yaw: float | None = None, costmap: str | Path | None = None,
            dwa: str | Path | None = None, move_base: str | Path | None = None,
            namespace: str = "/", cmd_vel: str = "cmd_vel",
            odom: str = "odom") -> GraphNavigation:
    """Read and check everything before anything is opened: the map, the parameter files,
    the start and the goal on free cells of the map, the topic names."""
    namespace = node_namespace(namespace)
    for what, name in (("--cmd-vel", cmd_vel), ("--odom", odom)):
        try:
            validate_topic_name(name)
        except ValueError as exc:
            raise NavigationError(f"{what} {name!r}: {str(exc).splitlines()[0]}") from None
    occupancy = load_map(map_file)
    planning = load_planning(costmap, dwa, move_base)
    x0, y0, yaw0 = initial_pose
    gx, gy = goal
    for value in (x0, y0, yaw0, gx, gy, 0.0 if goal_yaw is None else goal_yaw):
        if not math.isfinite(value):
            raise NavigationError(f"{value!r}: the start and the goal must be finite numbers")
    _on_free_cell(occupancy, "the initial pose", x0, y0)
    _on_free_cell(occupancy, "the goal", gx, gy)
    if goal_yaw is None:
        goal_yaw = math.atan2(gy - y0, gx - x0)
    return GraphNavigation(occupancy, (x0, y0, yaw0), (gx, gy, goal_yaw), planning.costmap,
                           planning.dwa, planning.move_base, transport, namespace, cmd_vel,
                           odom, planning.ignored)


# -- the nodes -------------------------------------------------------------------------------


def _map_server(context: Context, m: OccupancyMap, namespace: str) -> Any:
    """map_server: the map on ``map``, latched, published once."""
    from ...middleware.node import Node

    node = Node(context, "map_server", namespace)
    rows, cols = m.shape
    stamp = node.stamp()
    node.create_publisher(OCCUPANCY_GRID, "map", LATCHED).publish(node.message(
        OCCUPANCY_GRID, header={"stamp": stamp, "frame_id": MAP_FRAME},
        info={"map_load_time": stamp, "resolution": m.resolution, "width": cols,
              "height": rows, "origin": {"position": {"x": m.origin[0], "y": m.origin[1]},
                                         "orientation": {"w": 1.0}}},
        data=m.occupancy.reshape(-1)))
    return node


@dataclass
class Outage:
    """A time odometry did not come: from the last message before it to the first after (s
    on the run's clock), and how many the robot sent meanwhile that never arrived."""

    start_s: float
    end_s: float
    lost: int

    @property
    def seconds(self) -> float:
        """How long it lasted."""
        return self.end_s - self.start_s


@dataclass
class OdometryWatch:
    """What odometry arrived, when: the outages and the messages lost across them."""

    arrivals: list[float] = field(default_factory=list)
    stamps: list[float] = field(default_factory=list)

    def add(self, arrival: float, stamp: float) -> None:
        self.arrivals.append(arrival)
        self.stamps.append(stamp)

    def period(self) -> float:
        """The odometry's own period: the median step of its stamps (s)."""
        steps = np.diff(self.stamps)
        steps = steps[steps > 0]
        return float(np.median(steps)) if len(steps) else math.nan

    def outages(self, since: float, until: float | None = None) -> list[Outage]:
        """Every silence longer than :data:`OUTAGE_S`, on the run's clock from ``since``;
        with ``until`` (the run's end), also one that lasted to it (odometry that never
        came back), its losses counted at the odometry's period."""
        period = self.period()
        found = []
        for k in np.flatnonzero(np.diff(self.arrivals) > OUTAGE_S):
            gap = self.stamps[k + 1] - self.stamps[k]
            lost = max(0, round(gap / period) - 1) if math.isfinite(period) else 0
            found.append(Outage(self.arrivals[k] - since, self.arrivals[k + 1] - since, lost))
        if until is not None and self.arrivals and until - self.arrivals[-1] > OUTAGE_S:
            gap = until - self.arrivals[-1]
            lost = max(0, round(gap / period) - 1) if math.isfinite(period) else 0
            found.append(Outage(self.arrivals[-1] - since, until - since, lost))
        return found


def _localiser(context: Context, navigation: GraphNavigation, watch: OdometryWatch) -> Any:
    """The pose in the map from odometry alone: ``initial_pose`` composed with the odometry's
    pose (``map -> odom`` fixed at the start, as AMCL's initial pose sets it)."""
    from ...middleware.node import Node

    node = Node(context, "odometry_localiser", navigation.namespace)
    x0, y0, yaw0 = navigation.initial_pose
    c, s = math.cos(yaw0), math.sin(yaw0)
    pose = node.create_publisher(POSE, "fused_pose", 10)

    def on_odometry(msg: Any) -> None:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        xo, yo = float(p.x), float(p.y)
        yaw = yaw0 + 2.0 * math.atan2(float(q.z), float(q.w))
        watch.add(time.monotonic(), float(msg.header.stamp.sec)
                  + msg.header.stamp.nanosec * 1e-9)
        pose.publish(node.message(POSE, header={"stamp": msg.header.stamp,
                                                "frame_id": MAP_FRAME}, pose={
            "position": {"x": x0 + c * xo - s * yo, "y": y0 + s * xo + c * yo},
            "orientation": {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}}))

    node.create_subscription(ODOMETRY, navigation.odom, on_odometry, 10)
    return node


def command_type(context: Context, topic: str, timeout: float, say: Say) -> str:
    """The type the robot's ``cmd_vel`` subscriber has on the graph (Twist or TwistStamped),
    waiting up to ``timeout`` s for it to appear."""
    deadline = time.monotonic() + timeout
    said = False
    while True:
        types = {e.type_name for e in context.transport.graph()
                 if e.kind == "MS" and e.name == topic}
        if types - {TWIST, TWIST_STAMPED}:
            raise NavigationError(f"{topic} is subscribed as {sorted(types)}: the navigator "
                                  f"commands {TWIST} or {TWIST_STAMPED}")
        if len(types) == 1:
            return types.pop()
        if len(types) > 1:
            raise NavigationError(f"{topic} has subscribers of both {TWIST} and "
                                  f"{TWIST_STAMPED}: which robot is it?")
        if time.monotonic() > deadline:
            raise NavigationError(f"no robot subscribes to {topic} after {timeout:g} s: is it "
                                  "running, in this namespace, and reachable (--connect)?")
        if not said:
            say(f"waiting for the robot: nobody subscribes to {topic} yet")
            said = True
        context.spin_once(0.2)


# -- the run ---------------------------------------------------------------------------------


def run_navigate_on_graph(run_folder: RunFolder, navigation: GraphNavigation, *,
                          timeout: float = 180.0, say: Say = print,
                          show_progress: bool = True) -> dict[str, Any]:
    """Drive the robot on the graph to the goal (module docstring); writes the summary and
    returns it, or raises :class:`~.session.GoalNotReached`. ``timeout``: wall-clock seconds."""
    return run_task(run_folder, GraphNavigateTask(run_folder, navigation, timeout=timeout,
                                                  say=say, show_progress=show_progress),
                    say=say)


class GraphNavigateTask(Task):
    """A navigation of a robot elsewhere as a run (:func:`~..lifecycle.run_task`)."""

    name = "navigate"

    def __init__(self, run_folder: RunFolder, navigation: GraphNavigation, *, timeout: float,
                 say: Say, show_progress: bool) -> None:
        self.run_folder, self.navigation, self.timeout = run_folder, navigation, timeout
        self.say, self.show_progress = say, show_progress
        self.watch = OdometryWatch()
        self.navigator: NavigatorNode | None = None
        self.summary: dict[str, Any] = {
            "namespace": navigation.namespace, "map": navigation.map.path,
            "initial_pose": list(navigation.initial_pose), "goal": list(navigation.goal),
            "cmd_vel": navigation.topic(navigation.cmd_vel),
            "odom": navigation.topic(navigation.odom)}

    def open(self, opened: ExitStack) -> None:
        from ...middleware.context import Context

        for line in self.navigation.ignored:
            self.say(line)
        self.context = opened.enter_context(Context.open(self.navigation.transport))
        self.opened = opened
        self.bag = self.run_folder.file("navigate_bag")
        self.started = time.monotonic()

    def start(self) -> None:
        from ...middleware.recorder import Recorder

        navigation, context = self.navigation, self.context
        cmd_vel = navigation.topic(navigation.cmd_vel)
        kind = command_type(context, cmd_vel, START_TIMEOUT_S, self.say)
        _map_server(context, navigation.map, navigation.namespace)
        _localiser(context, navigation, self.watch)
        move_base, costmap = navigation.move_base, navigation.costmap
        gx, gy, goal_yaw = navigation.goal
        self.navigator = NavigatorNode(
            context, (gx, gy), costmap=costmap, dwa=navigation.dwa, goal_yaw=goal_yaw,
            patience=Patience(move_base.planner_patience, move_base.controller_patience,
                              move_base.oscillation_timeout, move_base.oscillation_distance),
            recovery=move_base.behaviors(costmap.circumscribed_radius),
            planner_frequency=move_base.planner_frequency, pose_timeout=OUTAGE_S,
            start_timeout=START_TIMEOUT_S, stamped_cmd_vel=kind == TWIST_STAMPED,
            no_pose=f"no odometry on {navigation.topic(navigation.odom)}",
            namespace=navigation.namespace,
            remappings={"cmd_vel": navigation.cmd_vel, "odom": navigation.odom})
        topics = [navigation.topic(t) for t in (*RECORDED, navigation.cmd_vel,
                                                navigation.odom)]
        Recorder(self.context, str(self.bag), topics, types={cmd_vel: kind}, quiet=True)
        self.summary.update(bag=str(self.bag), cmd_vel_type=kind)
        self.started = time.monotonic()

    def graph(self) -> Context:
        return self.context

    def served(self) -> Context:
        return self.context

    def run(self) -> None:
        navigator = self.navigator
        assert navigator is not None
        (x0, y0, _), (gx, gy, _) = self.navigation.initial_pose, self.navigation.goal
        self.say(f"navigating {self.navigation.namespace} from ({x0:g}, {y0:g}) to ({gx:g}, "
                 f"{gy:g}) on {self.navigation.map.path}")
        from tqdm import tqdm

        def remaining() -> float:
            x, y = navigator.pose[:2] if navigator.pose is not None else (x0, y0)
            return math.hypot(gx - x, gy - y)

        total, last_line = remaining(), 0.0
        with tqdm(total=round(total, 2), unit="m", disable=not self.show_progress,
                  leave=False, bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} m") as bar:
            while not navigator.done and self.elapsed() < self.timeout:
                self.context.spin_until(lambda: navigator.done, timeout=min(
                    0.5, self.timeout - self.elapsed()))
                covered = max(0.0, min(total, total - remaining()))
                if covered > bar.n:
                    bar.update(covered - bar.n)
                if not self.show_progress and self.elapsed() - last_line >= 1.0:
                    last_line = self.elapsed()
                    self.say(f"{last_line:.1f} s: {remaining():.2f} m to go")

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def stop(self, ended: BaseException | None) -> list[Step]:
        def wheels() -> None:
            if self.navigator is not None:
                self.navigator.halt()

        return [Step("stopping the wheels", wheels)]

    def way_out(self, ended: BaseException | None) -> list[Step]:
        return [Step("measuring", self._measure),
                Step("closing the bag and the graph", self.opened.close),
                Step("plotting", self._plot)]

    def _measure(self) -> None:
        navigator, navigation = self.navigator, self.navigation
        outages = self.watch.outages(self.started, time.monotonic())
        self.summary.update(
            seconds=round(self.elapsed(), 3), odometry_received=len(self.watch.arrivals),
            odometry_period_s=self.watch.period(),
            outages=[{**dataclasses.asdict(o), "seconds": o.seconds} for o in outages],
            odometry_lost=sum(o.lost for o in outages))
        if navigator is None:
            return
        gx, gy, goal_yaw = navigation.goal
        pose = navigator.pose
        cycles = np.array([c[1:3] for c in navigator.cycles], dtype=np.float64).reshape(-1, 2)
        self.summary.update(
            status=navigator.status.name, reason=navigator.reason,
            final_estimate=None if pose is None else dict(zip(("x", "y", "yaw"), pose,
                                                              strict=True)),
            goal_distance_m=None if pose is None else math.hypot(pose[0] - gx, pose[1] - gy),
            goal_yaw_error_rad=None if pose is None else abs(
                math.remainder(pose[2] - goal_yaw, 2 * math.pi)),
            xy_goal_tolerance_m=navigation.dwa.xy_goal_tolerance,
            path_length_m=float(np.sum(np.hypot(*np.diff(cycles, axis=0).T)))
            if len(cycles) > 1 else 0.0,
            stale_pose_cycles=navigator.stale_cycles, plans=len(navigator.plans),
            refused_before_driving=navigator.refused, warnings=list(navigator.warnings),
            recoveries=[dataclasses.asdict(r) for r in navigator.recoveries])

    def _plot(self) -> None:
        if self.navigator is not None:
            self.summary["plot"] = str(plot_on_map(
                self.navigation, self.navigator, self.summary["outages"], self.started,
                self.run_folder.file("navigate.png")))

    def verdict(self, ended: BaseException | None) -> None:
        if ended is not None:
            self.summary["status"] = "INTERRUPTED"
            self.summary["reason"] = f"interrupted: {interruption(ended)}"
        elif self.navigator is None or self.navigator.status is not NavigationStatus.SUCCEEDED:
            self.summary["reason"] = (self.navigator.reason if self.navigator else "") or \
                f"not at the goal after {self.timeout:g} s"

    def report(self, ended: BaseException | None) -> None:
        if ended is not None:
            return
        summary = self.summary
        if summary.get("status") != NavigationStatus.SUCCEEDED.name:
            raise GoalNotReached(f"navigation failed: {summary['reason']} (run folder: "
                                 f"{self.run_folder.path})", summary)
        outages = summary["outages"]
        gone = (f"; {len(outages)} outage(s) of odometry, {sum(o['seconds'] for o in outages):.1f}"
                f" s in all, {summary['odometry_lost']} message(s) lost" if outages else "")
        self.say(f"goal reached in {summary['seconds']:.1f} s, "
                 f"{summary['goal_distance_m'] * 1000:.0f} mm from it (odometry){gone}; "
                 f"bag {self.bag}, plot {summary.get('plot', 'not drawn')}")


def plot_on_map(navigation: GraphNavigation, navigator: NavigatorNode,
                outages: list[dict[str, Any]], started: float, path: Path) -> Path:
    """The map, the first plan, the pose driven on, the start and goal, and where the robot
    was when each outage began."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    m = navigation.map
    figure, ax = plt.subplots(figsize=(7, 6))
    lethal, unknown = m.lethal_and_unknown()
    ax.imshow(np.where(lethal, 0.2, np.where(unknown, 0.6, 1.0)), cmap="gray", vmin=0, vmax=1,
              origin="lower", extent=m.extent, interpolation="nearest")
    if navigator.plans:
        plan = navigator.plans[0][1]
        ax.plot(plan[:, 0], plan[:, 1], color="tab:blue", linewidth=1, label="first plan")
    cycles = np.array([c[:3] for c in navigator.cycles], dtype=np.float64).reshape(-1, 3)
    if len(cycles):
        ax.plot(cycles[:, 1], cycles[:, 2], color="tab:orange", linewidth=2,
                label="pose driven on (odometry)")
        for k, outage in enumerate(outages):
            at = int(np.argmin(np.abs(cycles[:, 0] - (outage["start_s"] + started))))
            ax.plot(cycles[at, 1], cycles[at, 2], "x", color="tab:red", markersize=10,
                    label="odometry lost (outage)" if k == 0 else None)
    ax.plot(*navigation.initial_pose[:2], "o", color="black", label="start")
    ax.plot(*navigation.goal[:2], "*", color="tab:red", markersize=12, label="goal")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="best", fontsize=8)
    ax.set_title(f"navigate {navigation.namespace}: {navigator.status.value}, "
                 f"{len(outages)} outage(s)")
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)
    return path
