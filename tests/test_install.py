"""Installed is the same as cloned (issue 26): the wheel carries every default a command uses.

The wheel is built from a copy of the project's own files (so the repository gets no build
folders), installed into a fresh virtual environment outside the repository, and the robot
commands run from another working directory, each writing its run folder there. The
environment takes servolab from the wheel only; its dependencies (numpy, OpenCV, zenoh...)
come from the test's own environment through a path entry, because tests run offline.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A fresh venv with servolab installed from its wheel; returns its bin folder."""
    tmp = tmp_path_factory.mktemp("install")
    source = tmp / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    shutil.copytree(ROOT / "src", source / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    wheels = tmp / "wheels"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps",
                    "--no-build-isolation", "--no-index", "-w", str(wheels), str(source)],
                   check=True, timeout=300, cwd=tmp)
    (wheel,) = wheels.glob("servolab-*.whl")
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=120)
    python = venv / "bin" / "python"
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; "
                                "print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True).stdout.strip())
    # the dependencies, as a plain path entry: the .pth files there (this checkout's editable
    # install among them) are not read, so servolab can only come from the wheel
    (site / "dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install",
                    "--quiet", "--no-deps", "--no-index", str(wheel)], check=True,
                   timeout=300)
    return venv / "bin"


def _run(bin_dir: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PATH"] = f"{bin_dir}{os.pathsep}{env.get('PATH', '')}"
    return subprocess.run([str(bin_dir / "servolab"), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def test_the_wheel_holds_every_shipped_default(installed: Path, tmp_path: Path) -> None:
    where = subprocess.run([str(installed / "python"), "-c",
                            "import servolab, servolab.robots.registry as r; "
                            "print(servolab.__file__); "
                            "print('\\n'.join(str(p) for p in r.shipped_files().values() "
                            "if not callable(p)))"],
                           cwd=tmp_path, capture_output=True, text=True, check=True,
                           env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    package, *files = where.stdout.split()
    venv = installed.parent
    assert Path(package).is_relative_to(venv), f"servolab came from {package}, not the wheel"
    assert files and all(Path(f).is_relative_to(venv) and Path(f).is_file() for f in files)


@pytest.mark.parametrize(("args", "folder"), [
    (["walk", "--steps", "1", "--no-progress"], "walk-"),
    (["drive", "line", "--distance", "0.5", "--no-progress"], "drive-"),
    (["flyball", "--duration", "2", "--no-progress"], "flyball-"),
])
def test_robot_commands_run_from_any_folder(installed: Path, tmp_path: Path, args: list[str],
                                            folder: str) -> None:
    result = _run(installed, tmp_path, *args)
    assert result.returncode == 0, result.stdout + result.stderr
    (run,) = (tmp_path / "runs").glob(f"{folder}*")
    summary = json.loads((run / "summary.json").read_text())
    assert summary["interrupted"] is None
    assert any(run.glob("*_bag")), sorted(p.name for p in run.iterdir())


def test_robots_lists_the_installed_files(installed: Path, tmp_path: Path) -> None:
    result = _run(installed, tmp_path, "robots")
    assert result.returncode == 0, result.stderr
    assert f"config:  {installed.parent}" in result.stdout
    shown = _run(installed, tmp_path, "robots", "show", "armstrong")
    assert shown.returncode == 0 and "controller_m14:" in shown.stdout


def test_the_wheel_requires_every_package_servolab_imports(installed: Path) -> None:
    """The venv above borrows its dependencies, so a dependency missing from pyproject.toml
    would not show there: every third-party module that src/servolab imports must come from a
    distribution the wheel's metadata requires."""
    import ast
    import importlib.metadata as metadata
    import re

    (dist_info,) = (installed.parent / "lib").glob("python*/site-packages/servolab-*.dist-info")
    required = {re.split(r"[ ;<>=!~\[(]", line.split(":", 1)[1].strip())[0].lower()
                .replace("_", "-")
                for line in (dist_info / "METADATA").read_text().splitlines()
                if line.startswith("Requires-Dist:") and "extra ==" not in line}
    imported: set[str] = set()
    for path in (ROOT / "src" / "servolab").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                imported |= {alias.name.split(".")[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                imported.add(node.module.split(".")[0])
    providers = metadata.packages_distributions()
    third_party = {m for m in imported if m in providers and m != "servolab"}
    missing = {m: providers[m] for m in third_party
               if not {d.lower().replace("_", "-") for d in providers[m]} & required}
    assert third_party, "the check found no third-party import: it looks in the wrong place"
    assert missing == {}, f"imported but not in the wheel's Requires-Dist: {missing}"


def test_installed_drive_on_a_pty_stops_on_sigterm(installed: Path, tmp_path: Path) -> None:
    """The whole chain as a lab meets it: the installed `servolab sim --pty` serves seed 000's
    two EX-106+ at 1 Mbps in real time, the installed `servolab drive` drives them from
    another folder, and SIGTERM mid-line stops the wheels (read back over the pty) with
    exit 143 and the summary written."""
    import signal

    from servolab.dynamixel.bus import Bus
    from tests.waiting import wait_for_line

    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env["PYTHONUNBUFFERED"] = "1"
    sim = subprocess.Popen([str(installed / "servolab"), "sim", "--pty", "--motors",
                            "ex106+:0-1", "--baud", "1000000", "--out", str(tmp_path / "sim")],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                           env=env, cwd=tmp_path)
    try:
        (pty,) = wait_for_line(sim, "/", timeout=30.0)[-1:]
        drive = subprocess.Popen([str(installed / "servolab"), "drive", "line", "--distance",
                                  "5", "--speed", "0.1", "--port", pty.strip(),
                                  "--no-progress", "--out", "run"], stdout=subprocess.PIPE,
                                 stderr=subprocess.STDOUT, text=True, env=env, cwd=tmp_path)
        try:
            wait_for_line(drive, "moving: 1 of 50 s", timeout=60.0)
            drive.send_signal(signal.SIGTERM)
            assert drive.wait(60) == 143
        finally:
            if drive.poll() is None:
                drive.kill()
                drive.wait()
            if drive.stdout is not None:
                drive.stdout.close()
        with Bus.open(pty.strip(), protocol=1, baudrate=1_000_000) as bus:
            assert [bus.read(i, "moving_speed", raw=True) for i in (0, 1)] == [0, 0]
    finally:
        sim.send_signal(signal.SIGINT)
        try:
            sim.wait(10)
        except subprocess.TimeoutExpired:
            sim.kill()
            sim.wait()
        if sim.stdout is not None:
            sim.stdout.close()
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["interrupted"] == "SIGTERM" and summary["wheels_after_stop"] == {"0": 0,
                                                                                    "1": 0}
