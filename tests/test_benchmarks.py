"""Smoke tests of the benchmarks, benchmarks/bus_cycle.py, benchmarks/middleware.py and
benchmarks/sim.py: each main runs end to end on a short run and writes its figures with
``--json``; the figures are checked there (every bus's or setup's present, finite, positive, and the
configurations the benchmark promises), the printed tables only for naming their ratio lines.
They check that the benchmarks work, not how fast anything is."""

from __future__ import annotations

import importlib.util
import json
import math
import os
import sys
from dataclasses import asdict
from pathlib import Path
from types import ModuleType

import pytest

#: holds the wall clock to deadlines: never beside another such test (tests/conftest.py)
pytestmark = pytest.mark.realtime

pytest.importorskip("dynamixel_sdk")

BENCHMARK = Path(__file__).resolve().parents[1] / "benchmarks" / "bus_cycle.py"


def _load(path: Path = BENCHMARK, name: str = "bus_cycle") -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while building
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def _positive(value: float) -> bool:
    return isinstance(value, int | float) and math.isfinite(value) and value > 0


# What the three buses are: (model, protocol, baud rate, motors), as bus_cycle.CONFIGS says.
BUSES = {"a": ("RX-28", 1, 57_142, 20), "b": ("RX-28", 1, 1_000_000, 20),
         "c": ("XM430-W210", 2, 1_000_000, 5)}
RETURN_DELAYS = [250, 0]  # raw: the factory 0.5 ms, then tuned to none


# The operations the driver-alone measurement times, per protocol (bus_cycle.make_ops).
REPLAY_OPS = [f"{p} {op}" for p in ("1.0", "2.0") for op in ("READ", "SYNC_WRITE", "SYNC_READ",
                                                             "sweep")]


@pytest.mark.timeout(60)
def test_bus_cycle_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bench = _load()
    out_json = tmp_path / "figures.json"
    # --quick: 3 calls, 1 round, 1 warm-up, 20 PINGs per pty server, the scan of IDs 0..31
    assert bench.main(["--quick", "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert (figures["cycles"], figures["rounds"], figures["warmup"]) == (3, 1, 1)

    # Issue 29: the pty server's reply lateness beside a bare responder measured in the same
    # run (timing varies with the machine: figures present, ordered and compared, not bounded)
    pty = figures["pty"]
    assert set(pty["servers"]) == {"bare", "sim_default", "sim"}
    for server in pty["servers"].values():
        seen = server["seen"]
        assert seen["n"] == 20 and 0 <= seen["p50_ms"] <= seen["p99_ms"] <= seen["max_ms"]
        assert server["seen_p99_vs_bare"] == pytest.approx(
            seen["p99_ms"] / pty["servers"]["bare"]["seen"]["p99_ms"])
    # and the scan of a mixed 1.0 + 2.0 bus (--quick: of IDs 0..31, which hold every motor,
    # done as the default scan is): every motor found, on the virtual wire as estimated
    # beforehand, and through a pty; against the SDK's way on the same wire and IDs
    scan = figures["scan"]
    assert scan["ids"] == [0, 31]
    assert scan["ours"]["found"] == scan["sdk"]["found"] == len(scan["motors"]) == 8
    assert scan["ours"]["wire_s"] == pytest.approx(scan["ours"]["estimate_s"], rel=0.03)
    assert scan["ours"]["wire_s"] < scan["goal_s"]
    # through a pty at real wire speed a reply that a busy machine delays past its wait is a
    # motor missed at retries=0, as `servolab scan` has it: the figures say whether all were
    # found (and the clean-clone run once missed one beside the other worker's tests); every
    # motor found is the virtual wire's check above, and tests/dynamixel/test_scan_fast.py's
    assert isinstance(scan["pty"]["all_found"], bool) and 0 <= scan["pty"]["found"] <= 8
    assert scan["ratio_ours_sdk"] == pytest.approx(scan["ours"]["wire_s"]
                                                   / scan["sdk"]["wire_s"])
    assert "5. Scan of a mixed bus" in out

    # The three buses, as the benchmark promises them.
    configs = figures["configs"]
    assert sorted(configs) == ["a", "b", "c"]
    for key, (model, protocol, baudrate, motors) in BUSES.items():
        config = configs[key]
        assert (config["model"], config["protocol"], config["baudrate"], len(config["ids"])) \
            == (model, protocol, baudrate, motors), (key, config)
        assert f"{baudrate} bps" in config["label"] and model in config["label"]
        assert f"protocol {protocol}.0" in config["label"]

    for key, config in configs.items():
        # Wire time: two return delays per bus; emulated, analytic and SDK figures positive,
        # the emulated wire time within 3 % of the one computed from the packet sizes.
        assert [row["return_delay_raw"] for row in config["wire"]] == RETURN_DELAYS, key
        bus = next(c for c in bench.CONFIGS if c.key == key)
        for row in config["wire"]:
            for name in ("emulated_ms", "analytic_ms", "sdk_emulated_ms", "max_rate_hz"):
                assert _positive(row[name]), (key, name, row)
            assert abs(row["emulated_ms"] - row["analytic_ms"]) <= 0.03 * row["analytic_ms"]
            assert abs(row["difference"]) <= 0.03, (key, row)
            expected = bench.analytic(bus, row["return_delay_raw"])
            assert (row["bytes_out"], row["bytes_in"]) == (expected["bytes_out"],
                                                          expected["bytes_in"]), (key, row)
        # Host CPU time of the cycle on replayed bytes: ours, ours SI and the SDK's, and
        # their ratio.
        for side in ("ours", "ours_si", "sdk"):
            assert _positive(config["cpu"][side]["host_us"]), (key, side, config["cpu"][side])
        assert _positive(config["cpu"]["ratio_ours_sdk"]), key
        # The cycle rate over the wire limit, per return delay, for both drivers: a share of
        # the limit (the host's time only adds to the wire's).
        assert [row["return_delay_raw"] for row in config["rates"]] == RETURN_DELAYS, key
        for row, wire in zip(config["rates"], config["wire"], strict=True):
            assert row["wire_limit_hz"] == pytest.approx(1e3 / wire["emulated_ms"])
            for side in ("ours", "sdk"):
                assert _positive(row[f"{side}_rate_hz"]), (key, side, row)
                assert 0 < row[f"{side}_share"] <= 1, (key, side, row)
                assert row[f"{side}_rate_hz"] == pytest.approx(
                    row[f"{side}_share"] * row["wire_limit_hz"])

    # The driver alone on recorded replies: READ, SYNC_WRITE, SYNC_READ and the full-state
    # sweep on each protocol, each with both drivers' figures and the ratio.
    replay = figures["replay"]
    assert sorted(replay) == sorted(REPLAY_OPS)
    for key, op in replay.items():
        assert op["label"], key
        for side in ("ours", "ours_si", "sdk"):
            assert _positive(op[side]["host_us"]), (key, side, op[side])
        assert op["ratio_ours_sdk"] == pytest.approx(op["ours"]["host_us"]
                                                     / op["sdk"]["host_us"])

    # The printed report names each bus's ratio line (its figures are checked above) and says
    # which goals are met; the JSON holds the same verdicts.
    assert out.strip(), "the benchmark printed nothing"
    for key in "abc":
        assert f"({key}) {configs[key]['label']}: ratio ours/sdk = " in out, out
    assert "Goals:" in out
    assert figures["goals"] and all(line.strip().startswith(("met:", "NOT met:"))
                                    for line in figures["goals"])
    for line in figures["goals"]:
        assert line in out


MIDDLEWARE = BENCHMARK.with_name("middleware.py")


MESSAGES = ("Twist", "Image")
SETUPS = [("servolab", 1), ("zenoh", 1), ("servolab", 2), ("zenoh", 2)]
PROCESSES = {1: "one process", 2: "two processes"}


@pytest.mark.slow
@pytest.mark.timeout(120)
def test_middleware_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/middleware.py --quick --runs 2: eight setups (Twist and Image; servolab and
    bare Zenoh; one and two processes) each echo every ping and count every flood message,
    twice, and the ratios servolab/zenoh come out finite in each run, with their spread over
    the runs; a Twist's publish costs are timed. Its child processes are gone afterwards."""
    bench = _load(MIDDLEWARE, "middleware_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--runs", "2", "--json", str(out_json)],
                      progress=lambda s: None) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert figures["sizes"] == {bench.SHORT_NAMES[k]: asdict(v) for k, v in bench.QUICK.items()}

    rows = figures["rows"]
    assert len(rows) == 8
    assert [(r["message"], r["engine"], r["processes"]) for r in rows] == [
        (m, e, p) for m in MESSAGES for e, p in SETUPS], rows
    assert all(r["setup"] == f"{r['engine']}, {PROCESSES[r['processes']]}" for r in rows)
    sizes = {r["message"]: r["cdr_bytes"] for r in rows}
    assert sizes == {"Twist": 52, "Image": 640 * 376 + 52}, sizes  # CDR of the two messages
    for r in rows:
        for name in ("latency_p50_us", "latency_p99_us", "throughput_msg_s", "throughput_mb_s"):
            assert _positive(r[name]), (name, r)
        assert r["latency_p99_us"] >= r["latency_p50_us"], r

    ratios = figures["ratios"]
    assert len(ratios) == 4
    assert [(q["message"], q["processes"]) for q in ratios] == [
        (m, p) for m in MESSAGES for p in (1, 2)], ratios
    for q in ratios:
        for name in ("latency_p50", "latency_p99", "time_per_message"):
            assert _positive(q[name]), (name, q)

    # The printed report names each ratio line (its figures are checked above).
    assert out.strip(), "the benchmark printed nothing"
    for q in ratios:
        assert f"ratio {q['message']} {PROCESSES[q['processes']]}: latency p50 x" in out, out
        assert f"spread {q['message']} {PROCESSES[q['processes']]}: latency p50 x" in out, out

    runs = figures["runs"]
    assert len(runs) == 2 and runs[-1]["ratios"] == ratios  # the report is the last run's
    assert all(len(run["rows"]) == 8 and len(run["ratios"]) == 4 for run in runs)
    assert "of 2 runs, messages per second in" in out
    assert set(figures["publish_costs_us"]) == {"put_us", "put_attachment_us", "publish_us"}
    assert all(_positive(v) for v in figures["publish_costs_us"].values())
    assert not _children_running("--child"), "an echo process outlived the benchmark"


def _children_running(marker: str) -> list[int]:
    """PIDs of this process's children whose command line holds ``marker`` (Linux /proc)."""
    found = []
    for entry in Path("/proc").glob("[0-9]*"):
        try:
            ppid = int((entry / "stat").read_text().rsplit(")", 1)[1].split()[1])
            cmdline = (entry / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, IndexError, ValueError):
            continue
        if ppid == os.getpid() and marker in cmdline:
            found.append(int(entry.name))
    return found


# -- benchmarks/sim.py: real-time factors of the simulation -----------------------------------
SIM = BENCHMARK.with_name("sim.py")


@pytest.mark.timeout(60)
def test_sim_benchmark_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    bench = _load(SIM, "sim_benchmark")
    monkeypatch.setattr(bench, "pin_to_one_core", lambda: "not pinned (test)")
    out_json = tmp_path / "sim.json"
    assert bench.main(["--seconds", "0.5", "--json", str(out_json)]) == 0
    printed = capsys.readouterr().out
    assert "real-time factor" in printed and "100x goal" in printed and "40x goal" in printed
    assert "The physics limit: MuJoCo's own step alone" in printed

    figures = json.loads(out_json.read_text())
    scenarios = figures["scenarios"]
    assert sorted(scenarios) == ["a", "b", "c", "d", "e", "f"]
    assert "57142 bps" in scenarios["a"]["title"] and "1000000 bps" in scenarios["b"]["title"]
    for key, s in scenarios.items():
        assert s["simulated_s"] == pytest.approx(0.5, abs=0.06), key
        assert math.isfinite(s["real_time_factor"]) and s["real_time_factor"] > 0, key
        # 1 ms physics steps (2 ms in MuJoCo, e and f): a step a simulated step length
        step = 0.002 if key in "ef" else 0.001
        assert s["physics_step_s"] == step, key
        assert s["physics_steps"] == pytest.approx(s["simulated_s"] / step, abs=1), key
        shares = s["shares"]
        assert set(shares) >= {"physics", "driver_and_port"}, key
        assert all(0.0 <= v <= 1.0 for v in shares.values()), (key, shares)
        assert sum(shares.values()) == pytest.approx(1.0, abs=1e-6), (key, shares)
    assert scenarios["d"]["transactions"] == 0          # the world alone: nobody on the bus
    assert scenarios["f"]["transactions"] == 0
    assert 0 < scenarios["e"]["mj_step_share"] < scenarios["e"]["shares"]["physics"]
    # the physics limit: the simulated seconds over the seconds MuJoCo's own step took in
    # the timed run; none where there is no MuJoCo
    limit = scenarios["e"]["physics_limit_rtf"]
    assert math.isfinite(limit) and limit > 0
    assert scenarios["a"]["physics_limit_rtf"] is None
    for key in "abce":
        assert scenarios[key]["transactions"] > 0 and scenarios[key]["state_rate_hz"] > 0
    # 20 Hz asked for; at 57142 bps the twenty READs do not fit in 50 ms, at 1 Mbps they do
    assert scenarios["a"]["state_rate_hz"] < 20.0
    assert scenarios["b"]["state_rate_hz"] == pytest.approx(20.0, abs=2.1)


GAIT = BENCHMARK.parent / "gait.py"
# The controller manager's buses benchmarks/gait.py promises: (baud rate, return delay raw).
MANAGER_BUSES = [(57_142, 250), (57_142, 0), (1_000_000, 250), (1_000_000, 0)]
# Its real-time walks over a pty: the baud rates, and what one step of the gait sends to the
# twelve leg motors (17 rows each, after the stand's 40 poses).
PTY_BAUDS = [57_142, 1_000_000]
GAIT_ROWS, LEG_MOTORS = 17, 12
FACTORY_DELAY_RAW = 250  # what servolab sim's RX-28 answer with


@pytest.mark.timeout(90)
def test_gait_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/gait.py --quick: the walk generator's ratio; the controller manager's bus
    owner on the four emulated buses (every figure finite and positive, the achieved rate the
    wire limit computed from the packet sizes, one READ per register slower than one READ of
    the 17 state bytes per motor); and the real-time walks over ``servolab sim --pty`` at
    57142 and 1 000 000 bps (rows delivered / commanded in 0..1, the state rate achieved
    within both its wire limit and the configured update_rate, that limit the one computed
    for the same bus in virtual time)."""
    bench = _load(GAIT, "gait_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert figures["quick"] is True
    assert _positive(figures["gait"]["ratio_loop_vectorised"])
    assert figures["gait"]["max_difference_deg"] < 1e-9

    manager = figures["manager"]
    assert manager["seed_ros_hz"] == [3.0, 4.0]
    buses = manager["buses"]
    assert [(b["baudrate"], b["return_delay_raw"]) for b in buses] == MANAGER_BUSES
    for bus in buses:
        assert bus["motors"] == 20 and bus["updates"] == manager["updates"], bus
        assert bus["transactions_per_update"] == 21, bus  # 20 READs + one SYNC_WRITE
        assert bus["goals_per_update"] == 20, bus          # every goal, in that SYNC_WRITE
        assert bus["goals_replaced"] == 0, bus             # one goal per motor per sweep
        for name in ("achieved_hz", "limit_hz", "ratio_achieved_limit", "per_register_hz",
                     "per_register_limit_hz", "ratio_per_register_limit",
                     "ratio_per_register_achieved", "manager_wire_ms", "owner_sweep_hz",
                     "owner_sweep_ms"):
            assert _positive(bus[name]), (name, bus)
        # Virtual time, sweeps back to back: the wire alone bounds the rate, and the owner
        # loses none of it (deterministic: no host time in it).
        assert 0.95 * bus["limit_hz"] <= bus["achieved_hz"] <= 1.01 * bus["limit_hz"], bus
        assert math.isclose(bus["ratio_achieved_limit"], bus["achieved_hz"] / bus["limit_hz"])
        assert math.isclose(bus["owner_sweep_hz"], bus["achieved_hz"], rel_tol=0.05), bus
        # a sweep's 20 READs take the update's time less the SYNC_WRITE's
        assert bus["owner_sweep_ms"] < 1e3 / bus["achieved_hz"], bus
        assert bus["per_register_limit_hz"] < bus["limit_hz"], bus
        assert bus["per_register_hz"] <= 1.01 * bus["per_register_limit_hz"], bus
        # The manager's own wire time is the one computed from the packet sizes.
        assert math.isclose(1e3 / bus["manager_wire_ms"], bus["limit_hz"], rel_tol=1e-6), bus
        assert bus["label"] in out
    # 57142 bps with the factory delay: one READ of the 17 state bytes per motor (an 8-byte
    # instruction, a 23-byte status) and the SYNC_WRITE of 8 + 3 x 20 bytes give 7.7 Hz (the
    # seed's ROS driver: 3-4 Hz).
    assert math.isclose(buses[0]["limit_hz"], 1 / (20 * ((8 + 23) * 10 / 57_142 + 0.5e-3)
                                                   + (8 + 3 * 20) * 10 / 57_142),
                        rel_tol=1e-9)
    assert "ratio achieved/limit" in out and "ratio per-register/one-READ" in out

    pty = figures["pty"]
    assert (pty["gait_rows"], pty["leg_motors"]) == (GAIT_ROWS, LEG_MOTORS)
    walks = pty["buses"]
    assert [w["baudrate"] for w in walks] == PTY_BAUDS[:1]  # --quick: the seed's bus only
    for walk in walks:
        assert walk["rows_played"] == GAIT_ROWS, walk
        # the rows that changed a leg motor's goal (a repeated goal cannot be told read back)
        assert 100 < walk["rows_commanded"] <= GAIT_ROWS * LEG_MOTORS, walk
        assert 0 <= walk["rows_delivered"] <= walk["rows_commanded"], walk
        assert 0.0 <= walk["ratio_delivered"] <= 1.0, walk
        assert math.isclose(walk["ratio_delivered"],
                            walk["rows_delivered"] / walk["rows_commanded"]), walk
        assert 0 <= walk["never_read_back"] <= walk["rows_commanded"] - walk["rows_delivered"]
        assert math.isclose(walk["row_period_ms"], 1e3 / 4.5), walk
        if walk["never_read_back"] < walk["rows_commanded"]:
            assert _positive(walk["worst_delay_ms"]), walk
            assert math.isclose(walk["ratio_worst_delay_row"],
                                walk["worst_delay_ms"] / walk["row_period_ms"]), walk
        if walk["rows_delivered"] == walk["rows_commanded"]:
            assert walk["worst_delay_ms"] <= walk["row_period_ms"], walk
        for name in ("state_rate_hz", "state_rate_wire_limit_hz", "ratio_state_limit",
                     "update_rate_hz", "ratio_state_asked", "goals_written", "walk_wall_s"):
            assert _positive(walk[name]), (name, walk)
        assert walk["update_rate_hz"] == 20.0, walk  # armstrong.yaml's, at both baud rates
        assert walk["state_rate_hz"] <= 1.02 * walk["state_rate_wire_limit_hz"], walk
        assert walk["state_rate_hz"] <= 1.02 * walk["update_rate_hz"], walk
        assert 0.0 < walk["ratio_state_limit"] <= 1.02, walk
        assert math.isclose(walk["ratio_state_limit"],
                            walk["state_rate_hz"] / walk["state_rate_wire_limit_hz"]), walk
        # the walk's wire limit (summary.json, 2 decimals) is the one part 2 computed for the
        # same bus: the emulated RX-28 answer after the factory return delay
        same = next(b for b in buses
                    if (b["baudrate"], b["return_delay_raw"]) == (walk["baudrate"],
                                                                  FACTORY_DELAY_RAW))
        assert math.isclose(walk["state_rate_wire_limit_hz"], same["limit_hz"], abs_tol=0.01)
        # every goal of the stand and the gait went out, 20 motors a row
        assert walk["goals_written"] >= 20 * (40 + GAIT_ROWS), walk
        assert walk["label"] in out
    assert "ratio delivered/commanded" in out and "ratio state/limit" in out


BASE = BENCHMARK.parent / "base.py"


@pytest.mark.timeout(60)
def test_base_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/base.py --quick: the base node's achieved control rate on the emulated buses
    of both bases, every figure finite and positive, within the wire-time limit of one cycle
    computed from the packet sizes, and 30 Hz at the node's default rate."""
    bench = _load(BASE, "base_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert figures["quick"] is True
    bases = figures["bases"]
    assert sorted(bases) == ["seed000", "turtlebot3_waffle"]
    assert (bases["seed000"]["model"], bases["seed000"]["protocol"]) == ("EX-106+", 1)
    assert (bases["turtlebot3_waffle"]["model"],
            bases["turtlebot3_waffle"]["protocol"]) == ("XM430-W210", 2)
    for name, base in bases.items():
        assert base["cycles"] == figures["cycles"], name
        for key in ("achieved_hz", "limit_hz", "ratio_achieved_limit", "wire_ms_per_cycle",
                    "host_us_per_cycle", "ratio_host_wire", "default_rate_hz",
                    "transactions_per_cycle", "bytes_per_cycle", "limit_bytes_out",
                    "limit_bytes_in"):
            assert _positive(base[key]), (name, key, base)
        assert all(_positive(d) for d in base["return_delay_ms"]), base
        assert base["achieved_hz"] <= 1.01 * base["limit_hz"], base
        assert base["default_rate_hz"] == pytest.approx(30.0, rel=0.01), base
        assert base["label"] in out
    # One SYNC_WRITE and one SYNC_READ a cycle on Protocol 2.0 (faster than a READ a side,
    # which the figures give for comparison); a READ a side on 1.0, which has no SYNC_READ.
    assert bases["seed000"]["reads_limit_hz"] is None
    waffle = bases["turtlebot3_waffle"]
    assert _positive(waffle["reads_limit_hz"])
    assert waffle["reads_limit_hz"] < waffle["limit_hz"]
    assert "ratio achieved/limit" in out and "SYNC_READ" in out


PLANNING = BENCHMARK.parent / "planning.py"


@pytest.mark.timeout(60)
def test_planning_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/planning.py --quick: per grid the first plan and the repairs after k = 1, 10,
    50 changes, D* Lite against our A* and scipy's Dijkstra, every time and ratio finite and
    positive, the planners' costs equal (the benchmark checks them), a verdict per grid and k;
    the first plan's ratios to the Dijkstra anchor of the same run (issue 30) and the
    incremental first search's figures beside them, printed."""
    bench = _load(PLANNING, "planning_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert figures["quick"] is True and figures["ks"] == [1, 10, 50]
    grids = figures["grids"]
    assert [g["size"] for g in grids] == list(bench.QUICK_SIZES)
    for grid in grids:
        assert 0.15 < grid["occupied_share"] < 0.25, grid["size"]
        first = grid["first"]
        for name in ("dstar_s", "astar_s", "dijkstra_s", "dijkstra_with_build_s",
                     "ratio_dstar_astar", "ratio_dstar_dijkstra",
                     "ratio_dstar_dijkstra_with_build", "cost", "dstar_incremental_s",
                     "dijkstra_build_s", "fast_build_s", "dijkstra_with_fast_build_s",
                     "ratio_dstar_dijkstra_with_fast_build",
                     "ratio_incremental_dijkstra_with_build", "speedup_over_incremental"):
            assert _positive(first[name]), (grid["size"], name, first)
        assert first["ratio_dstar_dijkstra_with_build"] == pytest.approx(
            first["dstar_s"] / (first["dijkstra_s"] + first["dijkstra_build_s"]))
        assert first["goal_met"] == (first["ratio_dstar_dijkstra_with_build"] <= 1.5)
        assert (f"D* Lite / Dijkstra = {first['ratio_dstar_dijkstra']:.2f}, D* Lite / "
                f"(Dijkstra+build) = {first['ratio_dstar_dijkstra_with_build']:.2f}") in out
        assert [r["k"] for r in grid["repairs"]] == [1, 10, 50]
        for r in grid["repairs"]:
            for name in ("cost", "repair_s", "astar_s", "dijkstra_s", "dijkstra_with_build_s",
                         "ratio_astar_repair", "ratio_dijkstra_repair",
                         "ratio_dijkstra_with_build_repair", "ratio_fastest_repair",
                         "repair_incremental_init_s", "repair_first_s",
                         "repair_incremental_init_first_s", "ratio_incremental_init_repair"):
                assert _positive(r[name]), (grid["size"], r["k"], name, r)
            assert r["ratio_astar_repair"] == pytest.approx(r["astar_s"] / r["repair_s"])
            assert isinstance(r["goal_met"], bool)
            assert r["goal_met"] == (r["ratio_fastest_repair"] >= 10.0)
    # The first plan's verdict is given on the goal's grid (1000²) only, not a --quick one.
    assert figures["first_goal"] == 1.5 and figures["first_goal_size"] not in bench.QUICK_SIZES
    assert len(figures["goals"]) == 3 * len(grids)
    assert all(line.startswith(("met:", "NOT met:")) for line in figures["goals"])
    assert "Goals:" in out and all(line in out for line in figures["goals"])


FLYTRACKER = BENCHMARK.parent / "flytracker.py"


@pytest.mark.timeout(90)
def test_flytracker_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/flytracker.py --quick: the tracker's and the bare OpenCV anchor's frames per
    second and their ratio, and the whole per-frame loop (track, control, the emulated bus, the
    log) with its latency p50/p99 against the 66 fps camera's frame period, every figure finite
    and positive, one logged record per frame looped."""
    bench = _load(FLYTRACKER, "flytracker_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert figures["quick"] is True
    assert figures["camera_fps"] == 66.0
    assert figures["frame_period_ms"] == pytest.approx(1e3 / 66)
    assert (figures["frames"], figures["repeats"]) == (bench.QUICK_FRAMES, bench.QUICK_REPEATS)
    for name in ("tracker", "bare", "loop"):
        fig = figures[name]
        assert _positive(fig["fps"]) and len(fig["fps_repeats"]) == figures["repeats"], name
        assert fig["ratio_camera"] == pytest.approx(fig["fps"] / 66.0), name
        assert f"{fig['fps']:.0f} fps = {fig['ratio_camera']:.1f}x the camera's 66" in out
    assert figures["ratio_tracker_bare"] == pytest.approx(figures["tracker"]["fps"]
                                                         / figures["bare"]["fps"])
    loop = figures["loop"]
    for name in ("latency_p50_ms", "latency_p99_ms", "latency_max_ms", "p50_share_of_period",
                 "p99_share_of_period", "simulated_wire_ms_per_frame"):
        assert _positive(loop[name]), (name, loop)
    assert loop["latency_p99_ms"] >= loop["latency_p50_ms"]
    assert loop["p99_share_of_period"] == pytest.approx(loop["latency_p99_ms"]
                                                        / figures["frame_period_ms"])
    # issue 28: the real-time loop on servolab sim --pty beside the in-process anchor, with
    # the timing every run's summary has (robots/treadmill/timing.py)
    realtime = figures["realtime"]
    assert {run["bus"] for run in realtime["runs"]} == {"emulated", "pty"}
    for run in realtime["runs"]:
        # a frame may be dropped by the queue of one on a loaded machine, and counted so
        assert run["error"] is None and run["handled"] >= 0.9 * run["recording_frames"], run
        assert run["handled"] + run["dropped_frames"] <= run["recording_frames"], run
        assert 0 < run["achieved_fps"] <= 66.0 * 1.1 and run["interval_ms"]["p99"] > 0, run
        assert run["ratio_camera"] == pytest.approx(run["achieved_fps"] / 66.0), run
    pty = next(run for run in realtime["runs"] if run["bus"] == "pty")
    assert pty["sim_instructions"] >= 2 * pty["handled"]  # a SYNC_WRITE and a SYNC_READ each
    assert "Real-time loop (issue 28)" in out
    assert sorted(loop["stage_us"]) == ["bus", "control", "log", "track"]
    # One 17-float64 record per frame looped (the warm-up's four, then every repeat's).
    looped = 4 + figures["repeats"] * figures["frames_per_repeat"]
    assert loop["records_logged"] == looped and loop["record_bytes"] == 17 * 8
    assert loop["log_bytes"] == looped * 17 * 8
    assert "ratio tracker/bare = " in out and "frame period" in out
    assert "host time only" in out and "virtual clock" in out


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_dds_quick_run(capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/dds.py --quick: servolab's DDS transport and bare Cyclone DDS, each between
    two processes, every ping echoed and every flood counted (a lost message ends the run
    with its reason), and the ratio printed."""
    bench = _load(BENCHMARK.with_name("dds.py"), "dds_bench")
    assert bench.main(["--quick"]) == 0
    out = capsys.readouterr().out
    for engine in ("bare", "servolab"):
        line = next(x for x in out.splitlines() if x.strip().startswith(engine))
        assert "msg/s" in line and " us" in line
    assert "ratio servolab/bare: latency p50 x" in out


@pytest.mark.slow
@pytest.mark.timeout(90)
def test_wakeups_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/wakeups.py --quick: a Twist every 2 ms from a servolab talker in a child
    process, received by servolab (the watcher's moment and the callback's) and by bare Zenoh;
    every message accounted for, each delay positive, the watcher before the callback, and
    the talker gone afterwards."""
    bench = _load(BENCHMARK.with_name("wakeups.py"), "wakeups_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)]) == 0
    figures = json.loads(out_json.read_text())
    count = figures["count"]
    assert len(figures["anchor_us"]) == count
    assert len(figures["zenoh_callback_us"]) >= count
    assert figures["received"] == [count]  # every message reached servolab's callback
    # those that found the executor idle have both moments (under load, not every one), the
    # watcher's before the callback's
    paired = list(zip(figures["watcher_us"], figures["callback_us"], figures["hop_us"],
                      strict=True))
    assert 0 < len(paired) <= count
    assert all(0 < watcher <= callback for watcher, callback, _ in paired)
    assert all(abs(callback - watcher - hop) < 1e-6 for watcher, callback, hop in paired)
    assert all(v > 0 for v in figures["zenoh_callback_us"])
    out = capsys.readouterr().out
    assert "watcher -> callback (the hop)" in out and "of a bare thread wake-up" in out
    assert not _children_running("--child"), "the talker outlived the benchmark"


@pytest.mark.timeout(90)
def test_view_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """benchmarks/view.py --quick: /joint_states (Armstrong's 21 joints) and a 640x376 mono8
    image, through servolab view and through foxglove-sdk's server alone, to one client; every
    latency and rate finite and positive, the same CDR bytes for both setups, the ratios
    servolab/sdk measured and printed. servolab view's and the client's threads are gone
    afterwards."""
    import threading

    pytest.importorskip("foxglove")
    bench = _load(BENCHMARK.with_name("view.py"), "view_bench")
    out_json = tmp_path / "figures.json"
    assert bench.main(["--quick", "--json", str(out_json)], progress=lambda s: None) == 0
    out = capsys.readouterr().out
    figures = json.loads(out_json.read_text())
    assert figures["quick"] is True
    rows = figures["rows"]
    assert [(r["message"], r["setup"]) for r in rows] == [
        (m, s) for m in ("JointState", "Image") for s in ("servolab", "sdk")], rows
    sizes = {(r["message"], r["setup"]): r["cdr_bytes"] for r in rows}
    assert sizes[("Image", "servolab")] == sizes[("Image", "sdk")] == 640 * 376 + 52
    assert sizes[("JointState", "servolab")] == sizes[("JointState", "sdk")] > 21 * 16
    for r in rows:
        for name in ("latency_p50_us", "latency_p99_us", "throughput_msg_s", "throughput_mb_s"):
            assert _positive(r[name]), (name, r)
        assert r["latency_p99_us"] >= r["latency_p50_us"], r
        assert 0 < r["delivered"] <= r["flood"], r
    ratios = figures["ratios"]
    assert [q["message"] for q in ratios] == ["JointState", "Image"]
    for q in ratios:
        for name in ("latency_p50", "latency_p99", "time_per_message", "rate"):
            assert _positive(q[name]), (name, q)
        assert f"ratio {q['message']}: latency p50 x{q['latency_p50']:.2f}" in out, out
    assert "foxglove-sdk" in out.splitlines()[0]
    assert not [t.name for t in threading.enumerate()
                if t.name in ("servolab-view", "view-bench-client") and t.is_alive()]


CONTROL = BENCHMARK.with_name("control.py")


@pytest.mark.slow
@pytest.mark.timeout(180)
def test_control_quick_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The update loop on a pty: the anchor, each asked rate's achieved rate and ratios."""
    bench = _load(CONTROL, "control_bench")
    out = tmp_path / "control.json"
    assert bench.main(["--joints", "2", "--seconds", "0.5", "--rates", "50", "--load", "1",
                       "--json", str(out)]) == 0
    figures = json.loads(out.read_text())
    assert set(figures["wire"]) == {"250", "0"}
    assert _positive(figures["anchor_hz"]) and _positive(figures["wire_limit_hz"])
    (row,) = figures["rates"]
    assert row["asked_hz"] == 50
    assert all(_positive(row[k]) for k in ("achieved_hz", "of_asked", "of_anchor"))
    printed = capsys.readouterr().out
    assert "of the wire limit" in printed and "of the anchor" in printed
