"""A real browser watching ``servolab walk --view``: headless Chromium plots a joint's angle.

``tests/view_client/browser.mjs`` launches headless Chromium (the build shipped inside the
``@sparticuz/chromium`` npm package, driven by ``puppeteer-core``; no system browser) on
``tests/view_client/page/plot.html``, where Foxglove's own client library
(``@foxglove/ws-protocol``'s ``FoxgloveClient`` over the browser's ``WebSocket``, CDR decoded
by ``@foxglove/rosmsg2-serialization``; bundled by esbuild) connects to the run with
Lichtblick's subprotocol ``foxglove.websocket.v1``, subscribes to ``/joint_states`` and draws
``left_knee``'s position over time on a canvas, the curve in pure blue. What the page decoded
must equal what the run's bag recorded (read back with ``mcap`` and ``mcap-ros2-support``), and
its screenshot must show the curve bending as the knee does.

With ``SERVOLAB_UPDATE_DOCS=1`` the screenshot is copied to ``docs/img/view_browser.png``,
where docs/view.md shows it (a test run otherwise leaves the repository as it was).

``make view-oracle`` installs the npm packages and bundles the page; where Node, the packages or
the bundle are missing the test skips saying so. It never reaches the network: the browser
opens a file and talks to the run on loopback.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import pytest

from tests.processes import run_to_end
from tests.viewclient import watched_run

# each runs a robot or a launch in other processes (and a browser): every core busy, so
# not beside the tests that hold the wall clock to a deadline (tests/conftest.py)
pytestmark = [pytest.mark.slow, pytest.mark.realtime]

REPO = Path(__file__).resolve().parents[2]
VIEW_CLIENT = REPO / "tests" / "view_client"
BROWSER_SCRIPT = VIEW_CLIENT / "browser.mjs"
#: what browser.mjs and the page need: ``make view-oracle`` installs and builds them
NEEDED = (VIEW_CLIENT / "node_modules" / "@sparticuz" / "chromium" / "package.json",
          VIEW_CLIENT / "node_modules" / "puppeteer-core" / "package.json",
          VIEW_CLIENT / "node_modules" / "@foxglove" / "ws-protocol" / "package.json",
          VIEW_CLIENT / "build" / "plot.bundle.js")
DOCS_IMAGE = REPO / "docs" / "img" / "view_browser.png"

SUBPROTOCOL = "foxglove.websocket.v1"  # Lichtblick's (and older Foxglove's)
TOPIC = "/joint_states"
JOINT = "left_knee"
#: samples the page waits for; ``walk --steps 1`` publishes 45 on /joint_states
COUNT = 25
#: the simulated walk plays at this many times real time while watched (--view-speed)
SPEED = "2"

#: page/plot.js's canvas (800 x 400) and plot area: margins left 60, right 20, top 30,
#: bottom 40; y autoscaled over the samples with 5 % padding, t from first to last sample.
WIDTH, HEIGHT = 800, 400
LEFT, RIGHT, TOP, BOTTOM = 60, WIDTH - 20, 30, HEIGHT - 40


def _browser() -> list[str]:
    """``node browser.mjs``; the test is skipped, saying why, where Node, the npm packages or
    the page's bundle are missing."""
    node = shutil.which("node")
    if node is None:
        pytest.skip("the browser test needs Node.js: node not found on PATH "
                    "(install Node 20, then run make view-oracle)")
    missing = [str(p.relative_to(VIEW_CLIENT)) for p in NEEDED if not p.exists()]
    if missing:
        pytest.skip(f"headless Chromium or the plot page is not installed ({', '.join(missing)} "
                    f"missing from {VIEW_CLIENT}): run make view-oracle (see "
                    f"{VIEW_CLIENT / 'install.log'})")
    return [node, str(BROWSER_SCRIPT)]


def _recorded_knee(bag: Path) -> list[tuple[tuple[int, int], float]]:
    """The bag's /joint_states as ((sec, nanosec), left_knee position), in order, decoded by
    mcap-ros2-support."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    found: list[tuple[tuple[int, int], float]] = []
    (path,) = sorted(bag.glob("*.mcap"))
    with path.open("rb") as f:
        for _, _, _, msg in make_reader(
                f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(topics=[TOPIC]):
            stamp = (int(msg.header.stamp.sec), int(msg.header.stamp.nanosec))
            found.append((stamp, float(msg.position[list(msg.name).index(JOINT)])))
    return found


def _watch_in_browser(out: Path, screenshot: Path) -> dict[str, Any]:
    """Run ``servolab walk --steps 1 --view PORT`` to its end with the browser watching it;
    what browser.mjs printed."""
    browser = _browser()
    with watched_run(["walk", "--steps", "1"], out, speed=SPEED) as url:
        # run_to_end fails the test if browser.mjs leaves Chromium running
        shown = run_to_end([*browser, "--url", url,
                            "--subprotocol", SUBPROTOCOL, "--topic", TOPIC, "--joint", JOINT,
                            "--count", str(COUNT), "--screenshot", str(screenshot),
                            "--timeout", "60"], timeout=90)
        assert shown.returncode == 0, f"browser.mjs: exit {shown.returncode}\n" \
            f"{shown.stdout[-3000:]}\n{shown.stderr[-3000:]}"
    result: dict[str, Any] = json.loads(shown.stdout)
    return result


def test_headless_chromium_plots_the_knee_of_a_watched_walk_as_its_bag_recorded_it(
        tmp_path: Path) -> None:
    import cv2
    import numpy as np

    screenshot = tmp_path / "view_browser.png"
    shown = _watch_in_browser(tmp_path / "run", screenshot)
    assert "HeadlessChrome" in shown["userAgent"]
    assert shown["ended"] == "count", shown
    assert shown["errors"] == [], shown["errors"]

    # (a) the page decoded what the bag recorded: COUNT consecutive messages, same stamps
    # and positions (float64 both ways: exactly equal)
    recorded = _recorded_knee(tmp_path / "run" / "walk_bag")
    stamps = [tuple(s) for s in shown["stamps"]]
    samples = shown["samples"]
    assert len(samples) == len(stamps) == COUNT
    order = [s for s, _ in recorded]
    first = order.index(stamps[0])
    assert stamps == order[first:first + COUNT]
    for (sec, nanosec), (t, angle), (_, knee) in zip(stamps, samples,
                                                     recorded[first:first + COUNT],
                                                     strict=True):
        assert t == sec + nanosec / 1e9
        assert angle == knee
    angles = [angle for _, angle in samples]
    assert max(angles) - min(angles) > 0.3  # the knee bends (rad) as the biped walks

    # (b) the screenshot shows the curve: blue pixels across the plot area, their rows
    # spanning most of its height, one at (next to) every sample
    image = cv2.imread(str(screenshot))
    assert image is not None, f"no image at {screenshot}"
    assert image.shape[:2] == (HEIGHT, WIDTH)
    b, g, r = (image[:, :, i].astype(int) for i in range(3))
    blue = (b >= 180) & (g <= 110) & (r <= 110)
    assert not blue[:, :LEFT - 2].any()  # nothing blue outside the plot: only the curve is
    rows, columns = np.nonzero(blue)
    assert len(set(columns.tolist())) > 0.9 * (RIGHT - LEFT)
    assert columns.min() <= LEFT + 3 and columns.max() >= RIGHT - 3
    assert rows.max() - rows.min() > 0.7 * (BOTTOM - TOP)  # not flat
    t0, t1 = samples[0][0], samples[-1][0]
    lo, hi = min(angles), max(angles)
    pad = 0.05 * (hi - lo)
    lo, hi = lo - pad, hi + pad
    for t, angle in samples:
        x = round(LEFT + (t - t0) / (t1 - t0) * (RIGHT - LEFT))
        y = round(TOP + (1 - (angle - lo) / (hi - lo)) * (BOTTOM - TOP))
        assert blue[max(0, y - 3):y + 4, max(0, x - 3):x + 4].any(), \
            f"no curve near the sample t={t:.3f} s, {angle:.3f} rad (pixel {x}, {y})"

    # (c) the docs show it, when asked to be remade
    if os.environ.get("SERVOLAB_UPDATE_DOCS") == "1":
        shutil.copyfile(screenshot, DOCS_IMAGE)
