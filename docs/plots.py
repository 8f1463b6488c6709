"""Make the figures of docs/dynamixel.md, sim.md, biped.md, mobile.md, navigation.md and
treadmill.md from the code itself: ``python docs/plots.py [DIR] [--quick]`` (``--quick``
shortens the 100 s treadmill run to 10 s, for the test).

Every figure is measured on emulated motors with the virtual clock, so they are exact and take
seconds to make. ``tests/test_docs.py`` runs this script, so a figure in the docs cannot drift
from what the code does.
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from servolab.dynamixel import Bus


def joint_moves(path: Path) -> None:
    """An RX-28 in joint mode, sent to three goals at three moving speeds."""
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for speed in (0.5, 1.5, 0.0):
        bus = Bus.open("emu://rx28:1", baudrate=1_000_000)
        clock = bus.port.clock
        bus.write(1, "torque_enable", 1)
        bus.write(1, {"goal_position": 1.0, "moving_speed": speed})
        t0, times, pos = clock.now(), [], []
        while clock.now() - t0 < 2.5:
            times.append(clock.now() - t0)
            pos.append(bus.read(1, "present_position"))
            clock.sleep(0.02)
        label = "moving_speed 0 (= no-load speed)" if speed == 0 else f"moving_speed {speed} rad/s"
        ax.plot(times, pos, label=label)
    ax.axhline(1.0, color="gray", linestyle="--", linewidth=0.8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("present_position (rad)")
    ax.set_title("Emulated RX-28, joint mode, goal_position 1.0 rad")
    ax.legend(loc="lower right", fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def cycle_time(path: Path) -> None:
    """Bus time of one cycle (write every goal, read every present position) vs motor count."""
    configs = [("rx28", 1, 57142, "RX-28, 1.0, 57142 bps: SYNC_WRITE + READ each"),
               ("rx28", 1, 1_000_000, "RX-28, 1.0, 1 Mbps: SYNC_WRITE + READ each"),
               ("xm430-w210", 2, 1_000_000, "XM430, 2.0, 1 Mbps: SYNC_WRITE + SYNC_READ")]
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for name, _, baud, label in configs:
        counts, millis = [], []
        for n in (1, 2, 5, 10, 15, 20):
            bus = Bus.open(f"emu://{name}:1-{n}", baudrate=baud)
            ids = list(range(1, n + 1))
            bus.sync_write("return_delay_time", {i: 0 for i in ids})
            clock = bus.port.clock
            t0 = clock.now()
            bus.sync_write("goal_position", {i: 0.1 for i in ids})
            bus.sync_read("present_position", ids)
            counts.append(n)
            millis.append((clock.now() - t0) * 1000)
        ax.plot(counts, millis, marker="o", label=label)
    ax.axhline(50, color="gray", linestyle=":", linewidth=0.8)
    ax.text(1, 51, "20 Hz", fontsize=8, color="gray")
    ax.set_xlabel("motors on the bus")
    ax.set_ylabel("bus time per cycle (ms)")
    ax.set_yscale("log")
    ax.set_title("Wire time of one control cycle (return delay 0)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def floor_world(path: Path) -> None:
    """The floor world's example: two wheels told to drive an arc, the base's true path beside
    what the driver reads back from the wheel motors."""
    from servolab.sim import DiffDriveFloor, Simulation, port_to

    sim = Simulation()
    world = DiffDriveFloor.example(sim)
    bus = Bus(port_to(sim.emulators[0], sim, 1_000_000))
    times, xs, ys, left, right = [], [], [], [], []
    while sim.now() < 6.0:
        truth = world.ground_truth()
        speeds = bus.sync_read("present_velocity", [1, 2])
        times.append(sim.now())
        xs.append(truth["x"])
        ys.append(truth["y"])
        left.append(speeds[1])
        right.append(speeds[2])
        sim.advance(0.05)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 3.6))
    ax1.plot(xs, ys)
    ax1.plot(xs[0], ys[0], "o", color="tab:green", label="start")
    ax1.set_aspect("equal")
    ax1.set_xlabel("x (m)")
    ax1.set_ylabel("y (m)")
    ax1.set_title("Ground truth: the base's path")
    ax1.legend(fontsize=8)
    ax2.plot(times, left, label="left wheel (ID 1)")
    ax2.plot(times, right, label="right wheel (ID 2)")
    ax2.set_xlabel("time (s)")
    ax2.set_ylabel("present_velocity (rad/s)")
    ax2.set_title("What the driver reads on the bus")
    ax2.legend(fontsize=8)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def biped(out: Path) -> None:
    """docs/biped.md's figures: the seed's gait (feet, joint angles) and a walk of two steps
    on the emulated Armstrong (commanded against present angles)."""
    import shutil
    import tempfile

    from servolab.gait.plots import plot_foot_positions, plot_joint_angles
    from servolab.gait.walking import generate_walk
    from servolab.robots.armstrong.run import load_motion, run_walk
    from servolab.runs import RunFolder

    walk = generate_walk()
    plot_foot_positions(walk, out / "gait_feet.png")
    plot_joint_angles(walk, out / "gait_joint_angles.png")
    with tempfile.TemporaryDirectory() as tmp:
        summary = run_walk(RunFolder.create("walk", tmp), load_motion(None), steps=2,
                           say=lambda text: None, show_progress=False)
        shutil.copy(str(summary["plot"]), out / "biped_walk.png")


def mobile(out: Path) -> None:
    """docs/mobile.md's figure: seed 000's robot drives a figure of eight on the floor."""
    import shutil
    import tempfile

    from servolab.robots.base.run import run_drive
    from servolab.runs import RunFolder

    with tempfile.TemporaryDirectory() as tmp:
        summary = run_drive(RunFolder.create("drive", tmp), "eight", radius=0.3, speed=0.1,
                            say=lambda text: None, show_progress=False)
        shutil.copy(str(summary["plot"]), out / "mobile_eight.png")
    with tempfile.TemporaryDirectory() as tmp:
        summary = run_drive(RunFolder.create("drive", tmp), "circle", radius=0.5, speed=0.2,
                            slip=0.05, slip_jitter=0.1, say=lambda text: None,
                            show_progress=False)
        shutil.copy(str(summary["plot"]), out / "mobile_slip.png")
    fusion(out / "mobile_fusion.png")


def fusion(path: Path) -> None:
    """Seed 000's D.4 fusion on a simulated circle: odometry drifting slowly (a random walk of
    0.05 a sample plus noise of 1), the tracker noisy with D.4's variances; as in
    tests/estimation/test_kalman.py."""
    import numpy as np

    from servolab.estimation.kalman import SEED_000_FUSION, fuse_seed_000

    rng = np.random.default_rng(0)
    t = np.linspace(0, 2 * np.pi, 1000)
    truth = np.column_stack([50 * np.cos(t), 50 * np.sin(t)])
    odometry = (truth + np.cumsum(rng.normal(0, 0.05, truth.shape), axis=0)
                + rng.normal(0, 1.0, truth.shape))
    tracker = truth + rng.normal(0, np.sqrt(SEED_000_FUSION.tracker_variance), truth.shape)
    fused = fuse_seed_000(odometry, tracker)

    def rmse(track: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum((track - truth) ** 2, axis=1))))

    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(*truth.T, color="black", linewidth=1, label="truth")
    ax.plot(*tracker.T, ".", markersize=2, alpha=0.4,
            label=f"tracker (RMSE {rmse(tracker):.2f})")
    ax.plot(*odometry.T, label=f"odometry (RMSE {rmse(odometry):.2f})")
    ax.plot(*fused.T, label=f"fused, D.4 (RMSE {rmse(fused):.2f})")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("Kalman fusion as seed 000's D.4 (simulated)")
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def navigation(out: Path) -> None:
    """docs/navigation.md's figures: per-image reprojection errors of a calibration on
    synthetic boards (like the seed's Figure C4), and a plan with and without inflation."""
    import tempfile

    import cv2
    import numpy as np

    from servolab.robots.navigation.plan import load_problem, plan, plot_plan
    from servolab.vision.calibration import calibrate
    from servolab.vision.synthetic import PinholeCamera, random_board_poses, render_checkerboard

    camera = PinholeCamera(fx=820.0, fy=805.0, cx=326.0, cy=236.0, width=640, height=480,
                           distortion=(-0.28, 0.11, 0.0012, -0.0008, -0.02))
    rng = np.random.default_rng(7)
    poses = random_board_poses(camera, (10, 7), 25.0, 16, rng)
    images = [render_checkerboard(camera, (10, 7), 25.0, r, t, noise_std=2.0, rng=rng)
              for r, t in poses]
    calib = calibrate(images, (10, 7), 25.0)
    fig, ax = plt.subplots(figsize=(6.4, 3.2))
    errors = np.asarray(calib.per_image_errors)
    ax.bar(np.arange(1, len(errors) + 1), errors)
    ax.axhline(float(np.mean(errors)), color="gray", linestyle="--",
               label=f"mean of the images {np.mean(errors):.3f} px")
    ax.set_xlabel("image")
    ax.set_ylabel("RMS reprojection error (px)")
    ax.set_title("Calibration on 16 synthetic views of a 10x7-square board")
    ax.legend(fontsize=8)
    fig.savefig(out / "navigation_calibration.png", dpi=110, bbox_inches="tight")
    plt.close(fig)

    grid = np.full((60, 90), 255, dtype=np.uint8)  # a room with two walls and a pillar
    grid[0, :] = grid[-1, :] = grid[:, 0] = grid[:, -1] = 0
    grid[0:40, 30:33] = 0
    grid[20:60, 58:61] = 0
    grid[38:46, 12:20] = 0
    with tempfile.TemporaryDirectory() as tmp:
        image = Path(tmp) / "room.png"
        cv2.imwrite(str(image), grid)
        for name, inflation in (("navigation_plan.png", True),
                                ("navigation_plan_no_inflation.png", False)):
            problem = load_problem(image, (8, 50), (82, 8), inflation=inflation)
            _, path = plan(problem)
            plot_plan(problem, path, out / name)


def navigation_loop(out: Path) -> None:
    """docs/navigation.md's runs of `servolab navigate`: the shipped scene, where an obstacle
    appears on the plan at 6 s, and a box's corner that D.3's DWA does not get round."""
    import contextlib
    import shutil
    import tempfile

    from servolab.robots.base.config import SHIPPED_DIR
    from servolab.robots.navigation.run import GoalNotReached, prepare, run_navigate
    from servolab.runs import RunFolder
    from servolab.sim.scene import DEFAULT_SCENE

    with tempfile.TemporaryDirectory() as tmp:
        run = RunFolder.create("navigate", Path(tmp) / "loop")
        run_navigate(run, prepare((3.3, 2.3)), say=lambda _: None, show_progress=False)
        shutil.copy(run.file("navigate.png"), out / "navigation_loop.png")
        text = DEFAULT_SCENE.read_text()
        scene = Path(tmp) / "corner.yaml"
        scene.write_text(text[:text.index("\nobstacles:") + 1] + "obstacles:\n"
                         "  - {box: {x: 1.9, y: 0.0, width: 0.2, depth: 1.6}}\n")
        shutil.copy(SHIPPED_DIR / "base_seed000.yaml", Path(tmp) / "base_seed000.yaml")
        run = RunFolder.create("navigate", Path(tmp) / "corner")
        with contextlib.suppress(GoalNotReached):  # the point: it gives up, oscillating
            run_navigate(run, prepare((3.3, 0.6), goal_yaw=0.0, scene=scene),
                         say=lambda _: None, show_progress=False)
        shutil.copy(run.file("navigate.png"), out / "navigation_corner.png")


def treadmill(out: Path, duration: float = 100.0) -> None:
    """docs/treadmill.md's figures: one synthetic frame as Listing 1 sees it (Figures 3 and
    13 of the thesis), and the analysis of a closed-loop run of ``duration`` s (Figures 14,
    16, 18, 20 and 21).
    """
    import shutil
    import tempfile

    import cv2
    import numpy as np

    from servolab.robots.treadmill.control import FlyControllerConfig
    from servolab.robots.treadmill.run import run_flyball
    from servolab.runs import RunFolder
    from servolab.vision.fly_render import FlyPose, render_fly
    from servolab.vision.fly_tracker import track_fly

    image, _ = render_fly(FlyPose(402.0, 151.0, 0.6), noise_std=4.0,
                          rng=np.random.default_rng(2))
    sighting = track_fly(image)
    config = FlyControllerConfig()
    _, mask = cv2.threshold(image, 50, 255, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    fig, ax = plt.subplots(figsize=(7.0, 4.4))
    ax.imshow(image, cmap="gray", vmin=0, vmax=255)
    biggest = max(contours, key=cv2.contourArea)[:, 0, :]
    ax.plot(*np.vstack([biggest, biggest[:1]]).T, color="tab:green", lw=1, label="contour")
    ax.plot(sighting.cx, sighting.cy, "o", mfc="none", color="magenta", label="centroid")
    length = 40
    ax.plot([sighting.cx - length * np.cos(sighting.theta),
             sighting.cx + length * np.cos(sighting.theta)],
            [sighting.cy - length * np.sin(sighting.theta),
             sighting.cy + length * np.sin(sighting.theta)], color="magenta", lw=1,
            label=f"axis, theta {np.degrees(sighting.theta):.1f}°")
    tx, ty, _ = config.target
    ax.add_patch(plt.Circle((tx, ty), config.dead_band_px, fill=False, color="red", lw=1,
                            label="dead band, 50 px"))
    ax.set_title(f"one 640 x 376 frame: the fly at ({sighting.cx:.1f}, {sighting.cy:.1f}), "
                 f"area {sighting.area:.0f} px²", fontsize=9)
    ax.legend(fontsize=7, loc="lower left")
    fig.savefig(out / "treadmill_frame.png", dpi=100, bbox_inches="tight")
    plt.close(fig)
    with tempfile.TemporaryDirectory() as tmp:
        run = RunFolder.create("flyball", Path(tmp) / "run")
        summary = run_flyball(run, duration=duration, seed=0, show_progress=False)
        shutil.copy(summary["plot"], out / "treadmill_run.png")


def main(argv: list[str]) -> None:
    quick = "--quick" in argv  # the docs test: every figure made, the long runs shortened
    argv = [a for a in argv if a != "--quick"]
    out = Path(argv[0]) if argv else Path(__file__).parent / "img"
    out.mkdir(parents=True, exist_ok=True)
    joint_moves(out / "rx28_joint_moves.png")
    cycle_time(out / "bus_cycle_time.png")
    floor_world(out / "floor_world.png")
    biped(out)
    mobile(out)
    navigation(out)
    navigation_loop(out)
    treadmill(out, duration=10.0 if quick else 100.0)
    print(f"figures written to {out}")


if __name__ == "__main__":
    main(sys.argv[1:])
