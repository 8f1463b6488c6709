"""``servolab teleop``'s run: two arms, a leader and a follower, for some episodes, recorded.

Each arm is an emulated one in this process (``emu://``, the default) or the serial port (or
pty, or pyserial URL) it is on. Emulated arms share one simulation: the follower in its
robot's world (``world="robot"``: the OpenMANIPULATOR-X on its table in MuJoCo, any URDF with
masses in MuJoCo), in MuJoCo (``"mujoco"``) or as bare motors (``"emulated"``); the leader held
by the scripted hand (:mod:`.hand`). With every arm emulated the run is in virtual time, as
fast as the computer allows, unless ``real_time``; with a port it is in real time.

Afterwards the run folder holds ``teleop_bag/`` (the schema: :mod:`servolab.robots.teleop`),
``teleop.png`` (each follower joint's goal and position, the episodes shaded) and
``summary.json`` (the loop's figures: :meth:`.loop.TeleopLoop.figures`, the wire limit, the
episodes, what ended the run and where the follower was held).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import ExitStack
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from ..errors import RobotValueError
from ..lifecycle import Step, Task, replaced, run_task
from ..registry import default_robot
from . import EMULATED, WORLDS
from .arms import TeleopArm
from .hand import Episodes
from .leader import Hand, leader_of
from .loop import LoopOptions, TeleopLoop, cycle_wire_s, state_wire_s
from .mapping import JointMap

if TYPE_CHECKING:
    from ...clock import Clock
    from ...dynamixel.bus import Bus
    from ...dynamixel.emulator import Emulator
    from ...runs import RunFolder
    from ...sim.simulation import Simulation
    from ..dynamixel_system import DynamixelSystem
    from ..plugin import RobotPlugin
    from .hand import HandScript
    from .recording import EpisodeBag

Say = Callable[[str], None]


@dataclass(frozen=True)
class Arm:
    """An arm's robot: its plug-in, URDF and Dynamixel block."""

    name: str
    plugin: RobotPlugin
    urdf: str
    source: str
    system: DynamixelSystem
    #: its prismatic joints (their units are metres)
    linear: frozenset[str]

    @classmethod
    def named(cls, name: str) -> Arm:
        """The robot ``name`` as a teleoperated arm; one line when it cannot be one."""
        from ..description import Description
        from ..dynamixel_system import dynamixel_system
        from ..registry import entry

        plugin = entry(name)
        if plugin.description is None:
            raise RobotValueError(f"{name} has no URDF: teleoperation takes an arm whose URDF "
                                  "names its Dynamixels in a <ros2_control> block")
        urdf, source = plugin.description(), f"{plugin.name}.urdf"
        system = dynamixel_system(urdf, source, default_model=plugin.default_model)
        kinds = {j.name: j.kind for j in Description.from_urdf(urdf, source).joints}
        return cls(plugin.name, plugin, urdf, source, system,
                   frozenset(j.name for j in system.joints if kinds.get(j.name) == "prismatic"))


@dataclass(frozen=True)
class TeleopRequest:
    """What to run (see the module docstring); checked by :func:`prepare` before anything
    opens."""

    #: the arm (both, unless ``leader_robot``); None: the robot that says it is
    #: ``servolab teleop``'s default
    robot: str | None = None
    leader_robot: str | None = None
    leader: str = EMULATED
    follower: str = EMULATED
    world: str = "robot"
    episodes: Episodes = field(default_factory=lambda: Episodes(10.0, 1, 2.0))
    seed: int = 0
    camera: bool = True
    real_time: bool = False
    options: LoopOptions = field(default_factory=LoopOptions)


@dataclass(frozen=True)
class Prepared:
    """A request with its two arms found and their joints mapped."""

    request: TeleopRequest
    leader: Arm
    follower: Arm
    mapping: JointMap


def prepare(request: TeleopRequest) -> Prepared:
    """The two arms and the joints' map, or one line saying why not, before a run folder is
    made or a port opened."""
    if request.world not in WORLDS:
        raise RobotValueError(f"world {request.world!r}: one of {', '.join(WORLDS)}")
    for role, port in (("leader", request.leader), ("follower", request.follower)):
        if port.startswith(EMULATED) and port != EMULATED:
            raise RobotValueError(f"--{role} {port}: {EMULATED} alone is the arm emulated "
                                  "here (its own motors, from its URDF)")
    follower = Arm.named(request.robot or default_robot("teleop"))
    leader = Arm.named(request.leader_robot) if request.leader_robot else follower
    return Prepared(request, leader, follower, JointMap(leader.system.joints,
                                                        follower.system.joints))


def run_teleop(run_folder: RunFolder, request: TeleopRequest | Prepared, *,
               say: Say = print, on_cycle: Callable[[TeleopLoop], None] | None = None
               ) -> dict[str, Any]:
    """Run it (see the module docstring); returns the summary, or raises what ended the run
    once the follower holds and the summary is written. ``on_cycle``: a test's hook."""
    prepared = request if isinstance(request, Prepared) else prepare(request)
    return run_task(run_folder, TeleopTask(run_folder, prepared, say, on_cycle), say=say)


class TeleopTask(Task):
    name = "teleop"

    def __init__(self, run_folder: RunFolder, prepared: Prepared, say: Say,
                 on_cycle: Callable[[TeleopLoop], None] | None) -> None:
        self.run_folder = run_folder
        self.prepared = prepared
        self.request = request = prepared.request
        self.say = say
        self.on_cycle = on_cycle
        self.simulation: Simulation | None = None
        self.world: Any = None
        self.script: HandScript | None = None
        #: the emulated leader's motors (None on a port)
        self.leader_emulator: Emulator | None = None
        self.bag: EpisodeBag | None = None
        self.loop: TeleopLoop | None = None
        self.follower: TeleopArm | None = None
        self.held: list[float] | None = None
        self.summary: dict[str, Any] = {
            "robot": prepared.follower.name, "leader_robot": prepared.leader.name,
            "leader": request.leader, "follower": request.follower,
            "world": request.world if request.follower == EMULATED else None,
            "asked": {"episodes": request.episodes.count, "seconds": request.episodes.seconds,
                      "reset_s": request.episodes.reset, "seed": request.seed,
                      "rate_hz": request.options.rate or None,
                      "state_rate_hz": request.options.state_rate,
                      "watchdog_s": request.options.watchdog}}

    # -- opening --------------------------------------------------------------------------------

    def open(self, opened: ExitStack) -> None:
        from ...clock import WallClock

        request, prepared = self.request, self.prepared
        follower_bus = self._bus(prepared.follower, request.follower, opened, follower=True)
        leader_bus = self._bus(prepared.leader, request.leader, opened, follower=False)
        leader = TeleopArm("leader", prepared.leader.system, leader_bus)
        follower = TeleopArm("follower", prepared.follower.system, follower_bus)
        simulation = self.simulation
        virtual = (simulation is not None and not request.real_time
                   and EMULATED == request.leader == request.follower)
        clock: Clock = simulation if virtual and simulation is not None else WallClock()
        if simulation is not None and not virtual:
            simulation.start_real_time()
            opened.callback(simulation.stop_real_time)
        for arm in (leader, follower):
            arm.check()
            arm.configure(streaming=arm is follower)
        self.follower = follower
        follower.hold()  # torque on where it is: it moves only once the loop engages it
        camera = self._camera(opened)
        bag = self._bag(leader, follower, camera is not None)
        self.loop = TeleopLoop(leader, follower, prepared.mapping, clock, request.options,
                               bag=bag, camera=camera, on_cycle=self.on_cycle)
        self.summary["wire"] = self._wire(leader, follower)
        self.summary["clock"] = "virtual" if virtual else "real time"

    def _bus(self, arm: Arm, port: str, opened: ExitStack, *, follower: bool) -> Bus:
        from ...dynamixel.bus import Bus

        system = arm.system
        if port != EMULATED:
            bus = Bus.open(port, protocol=system.protocol, baudrate=system.baudrate)
        else:
            bus = self._emulated(arm, follower)
        opened.callback(bus.close)
        return bus

    def _emulated(self, arm: Arm, follower: bool) -> Bus:
        """The arm's motors emulated in the run's simulation: the follower in its world, the
        leader under the scripted hand."""
        from ...dynamixel.bus import Bus
        from ...dynamixel.emulator import build_emulator
        from ...sim.emulated import port_to
        from ...sim.simulation import Simulation
        from .hand import HandScript, hand_on, swings

        system = arm.system
        emulator = build_emulator(system.bus().motor_spec().at_baudrate(system.baudrate))
        if follower:
            place = self._placement(arm)
            if place is None:
                self.simulation = Simulation()
                self.simulation.add_emulator(emulator)
            else:
                self.simulation, emulator, self.world = place(emulator)
        else:
            if self.simulation is None:
                self.simulation = Simulation()
            self.simulation.add_emulator(emulator)
            self.leader_emulator = emulator
            self.script = HandScript(swings(system.joints, _hand_homes(arm)),
                                     self.request.episodes, self.request.seed)
            hand_on(emulator, self.simulation, system.joints, self.script)
        return Bus(port_to(emulator, self.simulation, system.baudrate), system.protocol)

    def _placement(self, arm: Arm) -> Any:
        """How to put the emulated follower in its world (None: bare motors)."""
        from ..urdf_world import mujoco_placement

        world = self.request.world
        if world == "robot":
            served = arm.plugin.serve(arm.system.baudrate)
            if served.place is not None:
                return served.place
        if world == "emulated":
            return None
        place = mujoco_placement(arm.urdf, arm.system, arm.source)
        if place is None:
            raise RobotValueError(f"{arm.source}: --world {world} needs the links' masses "
                                  "(each moved link's <inertial>); --world emulated runs the "
                                  "follower's motors alone")
        return place

    def _camera(self, opened: ExitStack) -> Any:
        """The camera on the follower's MuJoCo world, or None (no such world, not asked, or
        no OpenGL here: said, and the run records without images)."""
        from ...sim.errors import SimError
        from ...sim.mujoco_world import MujocoWorld

        if not (self.request.camera and self.request.options.camera_rate > 0
                and isinstance(self.world, MujocoWorld) and self.simulation is not None):
            self.summary["camera"] = None
            return None
        from .recording import FollowerCamera

        try:
            camera = FollowerCamera(self.world, self.simulation.lock, opened)
        except SimError as exc:
            self.say(f"no camera images: {exc}")
            self.summary["camera"] = f"none: {exc}"
            return None
        self.summary["camera"] = {"topic": "/follower/camera/image/compressed",
                                  "rate_hz": self.request.options.camera_rate}
        return camera

    def _bag(self, leader: TeleopArm, follower: TeleopArm, camera: bool) -> EpisodeBag:
        from .recording import EpisodeBag

        self.bag = EpisodeBag(replaced(self.run_folder.file("teleop_bag")), leader.names,
                              follower.names, camera=camera)
        return self.bag

    def _wire(self, leader: TeleopArm, follower: TeleopArm) -> dict[str, Any]:
        """The wire limit of one cycle, from the packet sizes (Protocol 2.0 arms)."""
        if not leader.system.protocol == follower.system.protocol == 2:
            return {"protocol": "1.0: the wire limit is computed for Protocol 2.0 only"}
        delay = leader.return_delay()
        cycle = cycle_wire_s(len(leader.ids), len(follower.ids),
                             min(leader.bus.baudrate, follower.bus.baudrate), delay)
        state = state_wire_s(len(follower.ids), 20, follower.bus.baudrate,
                             follower.return_delay())
        return {"baudrate": leader.bus.baudrate, "leader_return_delay_s": delay,
                "cycle_s": cycle, "wire_limit_hz": 1.0 / cycle, "state_read_s": state}

    # -- running --------------------------------------------------------------------------------

    def run(self) -> None:
        loop, request, say = self.loop, self.request, self.say
        assert loop is not None
        episodes = request.episodes
        say(f"teleoperation: leader {self.prepared.leader.name} on {_where(request.leader)}, "
            f"follower {self.prepared.follower.name} on {_where(request.follower, self.world)};"
            f" {episodes.count} episode{'s' if episodes.count > 1 else ''} of "
            f"{episodes.seconds:g} s")
        engage = loop.engage()
        if engage > 0:
            say(f"the follower has reached the leader ({engage:.2f} s)")
        script = self.script
        with _Progress(episodes, say) as progress:
            loop.run(episodes, on_begin=script.begin_at if script is not None else None,
                     progress=progress.update)

    def stop(self, ended: BaseException | None) -> Sequence[Step]:
        def hold() -> None:
            if self.loop is not None:
                self.loop.interrupted()
            if self.follower is not None:
                self.held = self.follower.hold()

        return [Step("holding the follower", hold)]

    def way_out(self, ended: BaseException | None) -> Sequence[Step]:
        steps = []
        if self.bag is not None:
            steps.append(Step("closing the bag", self._close_bag))
        if self.loop is not None and self.loop.record.times:
            steps.append(Step("plotting", self._plot))
        return steps

    def _close_bag(self) -> None:
        assert self.bag is not None
        messages = self.bag.close()
        self.summary["bag"] = {"path": self.bag.path.name, "messages": messages,
                               "camera_frames": self.bag.frames}

    def _plot(self) -> None:
        from .plot import plot_run

        assert self.loop is not None
        self.summary["plot"] = plot_run(self.loop, self.run_folder).name

    def verdict(self, ended: BaseException | None) -> None:
        loop = self.loop
        if loop is None:
            return
        figures = loop.figures(self.prepared.follower.linear)
        wire = self.summary.get("wire", {})
        if "wire_limit_hz" in wire and figures["cycles"]:
            figures["of_wire_limit"] = float(figures["achieved_hz"]) / wire["wire_limit_hz"]
        self.summary["loop"] = figures
        stamp = loop.clock.ros_time
        self.summary["episodes"] = [
            {"index": e.index, "start_s": stamp(e.start), "end_s": stamp(e.end),
             "cycles": e.cycles, "complete": e.complete} for e in loop.record.episodes]
        if self.held is not None:
            self.summary["held"] = dict(zip(self.follower.names if self.follower else (),
                                            self.held, strict=True))

    def report(self, ended: BaseException | None) -> None:
        loop = self.summary.get("loop")
        if not loop:
            return
        complete = sum(e["complete"] for e in self.summary.get("episodes", []))
        arm = loop.get("tracking_error_arm_rad", {})
        line = (f"{complete} episode{'s' if complete != 1 else ''} recorded; "
                f"{loop['cycles']} cycles at {loop['achieved_hz']:.1f} Hz")
        if "of_wire_limit" in loop:
            line += f" ({loop['of_wire_limit']:.0%} of the wire limit)"
        if arm:
            line += (f"; tracking error p50 {arm['p50'] * 1e3:.1f} mrad, p99 "
                     f"{arm['p99'] * 1e3:.1f} mrad")
        self.say(line + f"; {loop['commands_lost']} of {loop['commands_checked']} checked "
                 "commands lost")
        self.say(f"the follower holds where it is (torque on); run folder: "
                 f"{self.run_folder.path}")


class _Progress:
    """A tqdm bar over each episode's seconds on a terminal; elsewhere (a log, a test) a line
    a second: ``episode 1 of 2: 3 of 10 s``."""

    def __init__(self, episodes: Episodes, say: Callable[[str], None]) -> None:
        import sys

        self.episodes, self.say = episodes, say
        self.show = sys.stderr.isatty()
        self.bar: Any = None
        self.k, self.said = -1, 0

    def __enter__(self) -> _Progress:
        return self

    def __exit__(self, *_: object) -> None:
        if self.bar is not None:
            self.bar.close()

    def update(self, k: int, elapsed: float) -> None:
        total = self.episodes.seconds
        if k != self.k:
            self.k, self.said = k, 0
            if self.show:
                from tqdm import tqdm

                if self.bar is not None:
                    self.bar.close()
                self.bar = tqdm(total=total, unit="s", leave=False,
                                desc=f"episode {k + 1} of {self.episodes.count}",
                                bar_format="{l_bar}{bar}| {n:.1f}/{total:.1f} s")
        elapsed = min(elapsed, total)
        if self.bar is not None and elapsed > self.bar.n:
            self.bar.update(elapsed - self.bar.n)
        elif not self.show and int(elapsed) > self.said:
            self.said = int(elapsed)
            self.say(f"episode {k + 1} of {self.episodes.count}: {self.said} of {total:g} s")


def _where(port: str, world: Any = None) -> str:
    if port != EMULATED:
        return port
    return "emulated motors" + (f" ({type(world).__name__})" if world is not None else "")


def _hand_homes(arm: Arm) -> Hand | None:
    """The scripted hand's home and swing of each joint: what the arm's leader plug-in says
    (:func:`.leader.leader_plugin`), else None (each joint's range decides)."""
    leader = leader_of(arm.name)
    return None if leader is None else leader.hand
