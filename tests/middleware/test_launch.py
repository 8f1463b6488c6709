"""Launch files: strict parsing with file:line:key errors, in-process runs, and supervision of
real child processes (output prefixed, required entries, SIGINT/SIGTERM, nothing left behind).

Every process a test starts is stopped by it; every endpoint is on loopback. Multi-process
supervision is tested with ``exec`` entries (plain ``python -c`` scripts), which need neither
Zenoh nor the ``servolab launch --process`` CLI; the one test of node groups in child processes
runs only once that CLI is there.
"""

from __future__ import annotations

import json
import math
import os
import queue
import re
import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from servolab.middleware.errors import LaunchError
from servolab.middleware.launch import (
    ZENOH_ENDPOINT,
    LaunchFile,
    child_command,
    child_environment,
    child_transports,
    exec_command,
    launch_main,
    load_launch,
    run_launch,
    run_process_group,
)
from servolab.middleware.transport import TransportOptions
from tests.processes import stop_process_tree
from tests.waiting import alive, wait_for_queued_lines, wait_gone

DEMO = "servolab.middleware.demo_nodes"
PY = json.dumps(sys.executable)  # JSON strings are YAML strings
SRC = str(Path(__file__).resolve().parents[2] / "src")


def write(tmp_path: Path, text: str, name: str = "robot.launch.yaml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def script(code: str) -> str:
    """An exec entry's command running ``code`` in this Python, as a YAML flow list."""
    return json.dumps([sys.executable, "-c", textwrap.dedent(code)])


def started_pids(lines: list[str]) -> dict[str, int]:
    found = (re.fullmatch(r"\[launch\] started (\S+) \(pid (\d+)\)", line) for line in lines)
    return {m[1]: int(m[2]) for m in found if m}


# -- parsing ---------------------------------------------------------------------------------

ERRORS = {
    "unknown key": ("""\
        nodes:
          - name: talker
            node: servolab.middleware.demo_nodes:Talker
            paramters: {rate: 10.0}     # <-
        """, "node 'talker': unknown key 'paramters' (did you mean 'parameters'?)"),
    "unknown top-level key": ("""\
        trasnport: zenoh                # <-
        nodes: [{name: a, node: m:C}]
        """, "unknown key 'trasnport'"),
    "missing name": ("""\
        nodes:
          - name: talker
            node: servolab.middleware.demo_nodes:Talker
          - node: servolab.middleware.demo_nodes:Listener   # <-
        """, "node #2: key 'name' missing"),
    "both node and exec": ("""\
        nodes:
          - name: talker
            node: servolab.middleware.demo_nodes:Talker
            exec: [echo, hi]            # <-
        """, "node 'talker': key 'exec': give 'node' or 'exec', not both"),
    "neither node nor exec": ("""\
        nodes:
          - name: talker                # <-
            namespace: /robot
        """, "node 'talker': key 'node' missing"),
    "node not module:Class": ("""\
        nodes:
          - name: talker
            node: servolab.middleware.demo_nodes.Talker   # <-
        """, "node 'talker': key 'node': 'servolab.middleware.demo_nodes.Talker' is not "
             "module:Class"),
    "duplicate name in a namespace": ("""\
        transport: zenoh
        nodes:
          - {name: talker, node: m:C, namespace: /robot}
          - {name: talker, node: m:C, namespace: robot, process: two}   # <-
        """, "node 'talker': key 'name': duplicate name /robot/talker (also on line 3)"),
    "machine not declared": ("""\
        machines:
          pc: {address: localhost}
        nodes:
          - name: talker
            node: m:C
            machine: robt               # <-
        """, "node 'talker': key 'machine': no machine 'robt' (machines: pc)"),
    "parameters file missing": ("""\
        nodes:
          - name: talker
            node: m:C
            parameters: [{rate: 1.0}, talker.yaml]   # <-
        """, "node 'talker': key 'parameters': file 'talker.yaml' not found"),
    "launch parameters file missing": ("""\
        parameters: params.yaml         # <-
        nodes: [{name: a, node: m:C}]
        """, "key 'parameters': file 'params.yaml' not found"),
    "second process with local transport": ("""\
        nodes:
          - {name: talker, node: m:C}
          - {name: listener, node: m:C, process: other}   # <-
        """, "node 'listener': key 'process': a second process needs transport: zenoh"),
    "exec with local transport": ("""\
        transport: local
        nodes:
          - {name: talker, node: m:C}
          - name: recorder
            exec: [servolab, bag, record, /cmd_vel]   # <-
        """, "node 'recorder': key 'exec': a second process needs transport: zenoh"),
    "process on two machines": ("""\
        transport: zenoh
        machines: {pc: {address: localhost}, robot: {address: robot.local}}
        nodes:
          - {name: a, node: m:C, machine: pc, process: p}
          - {name: b, node: m:C, machine: robot,
             process: p}                # <-
        """, "node 'b': key 'process': process 'p' has nodes on machines 'pc' and 'robot'"),
    "parameter value": ("""\
        nodes:
          - name: talker
            node: m:C
            parameters:
              rate: {x: [1, a]}         # <-
        """, "node 'talker': key 'parameters': rate.x: "),
    "not YAML": ("""\
        nodes:
          - name: talker
            node: m:C: D                # <-
        """, "not valid YAML (mapping values are not allowed here)"),
    "two default machines": ("""\
        machines:
          pc: {address: localhost, default: true}
          robot: {address: robot.local,
                  default: true}        # <-
        nodes: [{name: a, node: m:C}]
        """, "machine 'robot': key 'default': only one machine can be the default"),
    "required not a bool": ("""\
        nodes:
          - {name: a, node: m:C,
             required: yes please}      # <-
        """, "node 'a': key 'required': must be true or false"),
    "exec option on an exec entry": ("""\
        transport: zenoh
        nodes:
          - name: rec
            exec: [servolab, bag, record]
            remappings: {a: b}          # <-
        """, "node 'rec': key 'remappings' is for node entries, not exec ones"),
}


@pytest.mark.parametrize("case", list(ERRORS))
def test_errors_are_one_line_naming_file_line_and_key(tmp_path: Path, case: str) -> None:
    text, expected = ERRORS[case]
    text = textwrap.dedent(text)
    line = next(n for n, row in enumerate(text.splitlines(), 1) if "# <-" in row)
    path = write(tmp_path, text)
    with pytest.raises(LaunchError) as info:
        load_launch(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}:{line}: "), message
    assert expected in message


def test_a_full_file_parses_into_entries(tmp_path: Path) -> None:
    write(tmp_path, """\
        /**:
          ros__parameters: {speed: 0.2}
        """, "params.yaml")
    write(tmp_path, """\
        /robot/talker:
          ros__parameters: {rate: 20.0, count: 7}
        other:
          ros__parameters: {rate: 1.0}
        """, "talker.yaml")
    path = write(tmp_path, f"""\
        transport: zenoh
        zenoh: {{listen: [tcp/127.0.0.1:7447], connect: []}}
        machines:
          pc: {{address: localhost, default: true}}
          robot: {{address: robot.invalid}}
        parameters: params.yaml
        nodes:
          - name: talker
            node: {DEMO}:Talker
            namespace: robot
            parameters: [talker.yaml, {{count: 9, camera: {{width: 640}}}}]
            remappings: {{cmd_vel: /turtle/cmd_vel}}
            process: camera
            machine: robot
            required: true
          - name: talker              # the same name in another namespace is fine
            node: {DEMO}:Talker
          - name: recorder
            exec: servolab bag record /cmd_vel -o 'my rec' --connect {ZENOH_ENDPOINT}
        """)
    launch = load_launch(path)
    assert isinstance(launch, LaunchFile)
    assert (launch.transport, launch.listen, launch.connect) == ("zenoh",
                                                                 ["tcp/127.0.0.1:7447"], [])
    assert launch.parameters.for_node("/talker") == {"speed": 0.2}
    robot_talker, talker, recorder = launch.nodes
    assert robot_talker.fully_qualified_name == "/robot/talker"
    assert robot_talker.parameters == {"rate": 20.0, "count": 9, "camera.width": 640}
    assert robot_talker.remappings == {"cmd_vel": "/turtle/cmd_vel"}
    assert (robot_talker.process, robot_talker.machine, robot_talker.required) == (
        "camera", "robot", True)
    assert (talker.process, talker.machine, talker.required) == ("main", "pc", False)
    assert recorder.is_exec and recorder.process == ""
    assert recorder.command == ["servolab", "bag", "record", "/cmd_vel", "-o", "my rec",
                                "--connect", ZENOH_ENDPOINT]
    assert exec_command(recorder, "tcp/127.0.0.1:9")[:3] == [sys.executable, "-m", "servolab"]
    assert exec_command(recorder, "tcp/127.0.0.1:9")[-1] == "tcp/127.0.0.1:9"
    assert launch.process_groups() == {"camera": [robot_talker], "main": [talker]}
    assert launch.process_count() == 3
    # which entries run where: a local address, or the machine named
    assert launch.entries_for() == [talker, recorder]
    assert launch.entries_for("robot") == [robot_talker]
    with pytest.raises(LaunchError, match=r"no machine 'nas' \(machines: pc, robot\)"):
        launch.entries_for("nas")


def test_transport_options_and_child_endpoints(tmp_path: Path) -> None:
    path = write(tmp_path, """\
        transport: zenoh
        zenoh: {listen: [tcp/0.0.0.0:7447]}
        nodes: [{name: a, node: m:C}]
        """)
    launch = load_launch(path)
    options = launch.transport_options()
    assert (options.kind, options.listen, options.connect) == ("zenoh", ["tcp/0.0.0.0:7447"],
                                                               [])
    # the command line's endpoints replace the file's; its transport alone keeps them
    assert launch.transport_options(TransportOptions("zenoh", connect=["tcp/h:1"])).listen == []
    assert launch.transport_options(TransportOptions("zenoh")).listen == ["tcp/0.0.0.0:7447"]
    with pytest.raises(LaunchError, match="--listen and --connect need --transport zenoh"):
        launch.transport_options(TransportOptions("local", listen=["tcp/127.0.0.1:1"]))
    # given endpoints: the first child uses them, the others connect to it over loopback
    (first, second, third), endpoint = child_transports(options, 3)
    assert first.listen == ["tcp/0.0.0.0:7447"]
    assert second == third
    assert (second.listen, second.connect) == (["tcp/127.0.0.1:0"], ["tcp/127.0.0.1:7447"])
    assert endpoint == "tcp/127.0.0.1:7447"
    # none given: a free loopback port picked now
    (first, second), endpoint = child_transports(TransportOptions("zenoh"), 2)
    assert re.fullmatch(r"tcp/127\.0\.0\.1:\d+", endpoint) and not endpoint.endswith(":0")
    assert (first.listen, first.connect) == ([endpoint], [])
    assert second.connect == [endpoint]
    argv = child_command(launch, "main", first)
    assert argv[:5] == [sys.executable, "-m", "servolab", "launch", str(path.resolve())]
    assert argv[5:] == ["--process", "main", "--transport", "zenoh", "--listen", endpoint,
                        "--domain-id", "0"]


# -- checks before anything starts -----------------------------------------------------------

@pytest.mark.parametrize(("node", "expected"), [
    ("servolab.middleware.no_such_module:Talker",
     "key 'node': no module named 'servolab.middleware.no_such_module'"),
    (f"{DEMO}:Talkr", f"key 'node': module '{DEMO}' has no class 'Talkr'"),
    (f"{DEMO}:TWIST", f"key 'node': {DEMO}:TWIST is not a Node subclass"),
])
def test_node_classes_are_imported_before_anything_starts(tmp_path: Path, node: str,
                                                          expected: str) -> None:
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - {{name: listener, node: {DEMO}:Listener}}
          - name: sleeper
            exec: {script("import time; time.sleep(60)")}
          - name: talker
            node: {node}
        """)
    lines: list[str] = []
    with pytest.raises(LaunchError) as info:
        run_launch(load_launch(path), out=lines.append)
    assert str(info.value) == f"{path}:7: node 'talker': {expected}"
    assert lines == []  # nothing started


def test_exec_commands_are_looked_up_before_anything_starts(tmp_path: Path) -> None:
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - name: sleeper
            exec: {script("import time; time.sleep(60)")}
          - name: tool
            exec: [no-such-command-for-servolab, run]
        """)
    lines: list[str] = []
    with pytest.raises(LaunchError, match=r":6: node 'tool': key 'exec': command "
                                          "'no-such-command-for-servolab' not found"):
        run_launch(load_launch(path), out=lines.append)
    assert lines == []


def test_nothing_to_run_here_and_bad_arguments_are_errors(tmp_path: Path) -> None:
    path = write(tmp_path, """\
        machines: {robot: {address: robot.invalid, default: true}}
        nodes: [{name: a, node: m:C}]
        """)
    with pytest.raises(LaunchError, match=r"nothing runs on this computer .* --machine"):
        run_launch(load_launch(path))
    with pytest.raises(LaunchError, match="--machine and --process cannot be combined"):
        launch_main(path, machine="robot", process="main")
    with pytest.raises(LaunchError, match=r"no process 'camera' \(processes: main\)"):
        launch_main(path, process="camera")


# -- in this process -------------------------------------------------------------------------

def test_local_launch_runs_in_process_until_the_required_talker_ends(tmp_path: Path) -> None:
    write(tmp_path, """\
        talker:
          ros__parameters: {count: 5}
        """, "params.yaml")
    path = write(tmp_path, f"""\
        parameters: params.yaml
        nodes:
          - name: talker
            node: {DEMO}:Talker
            parameters: {{rate: 100.0}}
            required: true
          - name: listener
            node: {DEMO}:Listener
        """)
    lines: list[str] = []
    assert run_launch(load_launch(path), out=lines.append) == 0
    assert lines[:2] == [f"[launch] started talker (in process {os.getpid()})",
                         f"[launch] started listener (in process {os.getpid()})"]
    assert lines[-2:] == ["[launch] stopped talker", "[launch] stopped listener"]
    sent = [line for line in lines if line.startswith("[/talker] ")]
    assert sent == [f"[/talker] INFO sent cmd_vel {k}" for k in range(1, 6)]
    # The talker shuts the context down right after its 5th message, so the listener's last
    # delivery may never run; every one it did hear is a message sent, in order.
    heard = [line for line in lines if line.startswith("[/listener] ")]
    expected = [f"[/listener] INFO heard linear.x=0.100 angular.z={0.5 * math.sin(k / 10):.3f}"
                for k in range(1, 6)]
    assert len(heard) >= 4
    assert heard == expected[:len(heard)]


def test_run_process_group_runs_one_group_and_logs_to_stdout(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = write(tmp_path, f"""\
        nodes:
          - {{name: talker, node: {DEMO}:Talker, namespace: /robot,
             parameters: {{rate: 100.0, count: 3}}}}
        """)
    assert run_process_group(load_launch(path), "main", TransportOptions()) == 0
    out = capsys.readouterr().out.splitlines()
    assert [line for line in out if line.startswith("[/robot/talker]")] == [
        f"[/robot/talker] INFO sent cmd_vel {k}" for k in (1, 2, 3)]
    # and through the CLI's entry point, as `servolab launch FILE --process main` runs it
    lines: list[str] = []
    assert launch_main(path, process="main", out=lines.append) == 0
    assert "[/robot/talker] INFO sent cmd_vel 3" in lines


# -- supervised child processes --------------------------------------------------------------

def test_required_exit_stops_the_others_and_no_child_survives(tmp_path: Path) -> None:
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - name: printer
            exec: {script("print('one'); print('two')")}
            required: true
          - name: sleeper
            exec: {script('''
                import subprocess, sys, time
                child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
                print("grandchild", child.pid, flush=True)
                time.sleep(60)''')}
        """)
    lines: list[str] = []
    start = time.monotonic()
    assert run_launch(load_launch(path), out=lines.append) == 0
    assert time.monotonic() - start < 10
    pids = started_pids(lines)
    assert set(pids) == {"printer", "sleeper"}
    assert "[printer] one" in lines and "[printer] two" in lines
    stop = lines.index("[launch] printer exited with 0; stopping the others (required)")
    assert lines.index("[printer] two") < stop
    assert any(line.startswith("[launch] sleeper ") for line in lines[stop + 1:])
    for pid in pids.values():
        assert not alive(pid)
    grandchild = [int(line.split()[-1]) for line in lines if "] grandchild " in line]
    for pid in grandchild:  # the SIGINT went to the sleeper's whole process group
        assert wait_gone(pid), f"grandchild {pid} survived"


def test_a_child_ignoring_sigint_gets_sigterm_and_the_required_code_is_returned(
        tmp_path: Path) -> None:
    flag = tmp_path / "ignoring"
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - name: stubborn
            exec: {script(f'''
                import pathlib, signal, time
                signal.signal(signal.SIGINT, signal.SIG_IGN)
                pathlib.Path({str(flag)!r}).touch()
                time.sleep(60)''')}
          - name: worker
            exec: {script(f'''
                import pathlib, sys, time
                while not pathlib.Path({str(flag)!r}).exists():
                    time.sleep(0.01)
                sys.exit(3)''')}
            required: true
        """)
    lines: list[str] = []
    assert run_launch(load_launch(path), out=lines.append, stop_timeout=0.3) == 3
    assert "[launch] worker exited with 3; stopping the others (required)" in lines
    assert "[launch] stubborn still running after SIGINT; sending SIGTERM" in lines
    assert "[launch] stubborn was ended by SIGTERM" in lines
    assert not any(alive(pid) for pid in started_pids(lines).values())


def test_when_every_child_ends_the_first_failure_is_the_exit_code(tmp_path: Path) -> None:
    done = tmp_path / "ok-done"
    # bad fails only once ok has done its work (it leaves a file last); it gives up with 5
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - name: ok
            exec: {script(f'''
                import pathlib
                print('fine')
                pathlib.Path({str(done)!r}).touch()''')}
          - name: bad
            exec: {script(f'''
                import pathlib, sys, time
                end = time.monotonic() + 15
                while not pathlib.Path({str(done)!r}).exists() and time.monotonic() < end:
                    time.sleep(0.01)
                sys.exit(4 if pathlib.Path({str(done)!r}).exists() else 5)''')}
        """)
    lines: list[str] = []
    assert run_launch(load_launch(path), out=lines.append) == 4
    assert "[launch] ok exited with 0" in lines
    assert "[launch] bad exited with 4" in lines
    assert lines[-1] == "[launch] every process has exited"


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_to_the_supervisor_stops_everything(tmp_path: Path,
                                                     sig: signal.Signals) -> None:
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - name: sleeper
            exec: {script("import time; print('ready', flush=True); time.sleep(600)")}
          - name: napper
            exec: {script("import time; print('ready', flush=True); time.sleep(600)")}
        """)
    code = ("import sys; from servolab.middleware.launch import load_launch, run_launch; "
            "sys.exit(run_launch(load_launch(sys.argv[1])))")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")]))
    supervisor = subprocess.Popen([sys.executable, "-c", code, str(path)], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                  process_group=0)
    lines: queue.Queue[str] = queue.Queue()
    seen: list[str] = []
    reader = threading.Thread(target=lambda: [lines.put(line.rstrip("\n"))
                                              for line in supervisor.stdout or ()], daemon=True)
    reader.start()
    try:
        wait_for_queued_lines(lines, seen, {"[sleeper] ready", "[napper] ready"}, timeout=15)
        supervisor.send_signal(sig)
        assert supervisor.wait(timeout=15) == 128 + sig  # as a shell reports a signal
        reader.join(timeout=5)
        while not lines.empty():
            seen.append(lines.get())
    finally:
        if supervisor.poll() is None:
            os.killpg(supervisor.pid, signal.SIGKILL)
            supervisor.wait()
        for pid in started_pids(seen).values():
            if alive(pid):
                os.killpg(pid, signal.SIGKILL)
    assert f"[launch] {sig.name}: stopping everything" in seen
    pids = started_pids(seen)
    assert set(pids) == {"sleeper", "napper"}
    assert not any(alive(pid) for pid in pids.values())


def test_a_launcher_killed_mid_stop_leaves_no_child_behind(tmp_path: Path) -> None:
    """What a test does with a launch that will not end (tests/processes.py,
    stop_process_tree): SIGTERM to the launcher, which starts stopping its children; here
    they ignore SIGINT and SIGTERM and the launcher is killed before its own grace periods
    end, as a timed-out subprocess.run would kill it. Its children, each the leader of a
    process group of its own, and theirs are killed all the same."""
    stubborn = '''
        import signal, subprocess, sys, time
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)
        child = subprocess.Popen([sys.executable, "-c", "import signal, time; "
                                  "signal.signal(signal.SIGINT, signal.SIG_IGN); "
                                  "signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                                  "print('ready', flush=True); time.sleep(600)"],
                                 stdout=subprocess.PIPE, text=True)
        child.stdout.readline()  # the grandchild ignores the signals too by now
        print("grandchild", child.pid, flush=True)
        time.sleep(600)'''
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - name: one
            exec: {script(stubborn)}
          - name: two
            exec: {script(stubborn)}
        """)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([SRC, os.environ.get("PYTHONPATH", "")]))
    launcher = subprocess.Popen([sys.executable, "-m", "servolab", "launch", str(path)],
                                env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True)
    lines: queue.Queue[str] = queue.Queue()
    seen: list[str] = []
    reader = threading.Thread(target=lambda: [lines.put(line.rstrip("\n"))
                                              for line in launcher.stdout or ()], daemon=True)
    reader.start()
    try:
        deadline = time.monotonic() + 60  # until both children say their own child is up
        while sum("] grandchild " in line for line in seen) < 2:
            assert time.monotonic() < deadline, f"the children never started: {seen}"
            try:
                seen.append(lines.get(timeout=max(0.0, deadline - time.monotonic())))
            except queue.Empty:
                continue
        children = started_pids(seen)
        grandchildren = [int(line.split()[-1]) for line in seen if "] grandchild " in line]
        assert set(children) == {"one", "two"} and len(grandchildren) == 2
        # the launcher's own grace period for SIGINT is STOP_TIMEOUT (5 s): 0.5 s is less
        how, killed = stop_process_tree(launcher, stop_timeout=0.5)
    finally:
        stop_process_tree(launcher, stop_timeout=0.5)
        if launcher.stdout is not None:
            launcher.stdout.close()
        reader.join(timeout=5)
    assert "killed" in how, how
    assert set(children.values()) | set(grandchildren) <= set(killed)
    for pid in [*children.values(), *grandchildren]:
        assert not alive(pid), f"{pid} survived"


@pytest.mark.slow
def test_node_groups_run_as_child_processes_over_zenoh(tmp_path: Path) -> None:
    path = write(tmp_path, f"""\
        transport: zenoh
        nodes:
          - {{name: listener, node: {DEMO}:Listener, process: ears}}
          - name: talker
            node: {DEMO}:Talker
            parameters: {{rate: 20.0, count: 30}}
            process: mouth
            required: true
        """)
    lines: list[str] = []
    assert run_launch(load_launch(path), out=lines.append) == 0
    assert [line for line in lines if line.startswith("[talker] [/talker] INFO sent")] == [
        f"[talker] [/talker] INFO sent cmd_vel {k}" for k in range(1, 31)]
    assert any(line.startswith("[listener] [/listener] INFO heard") for line in lines)
    assert "[launch] talker exited with 0; stopping the others (required)" in lines
    assert not any(alive(pid) for pid in started_pids(lines).values())


def test_shipped_launch_files_load() -> None:
    configs = Path(__file__).resolve().parents[2] / "configs"
    files = sorted(configs.glob("*.launch.yaml"))
    assert files
    for path in files:
        launch = load_launch(path)
        assert launch.nodes, path


# -- rclpy-shaped node classes and exec entries (issue 32, D5) -------------------------------

#: Node classes written as for rclpy, on servolab.rclpy: one takes rclpy's Node signature
#: (node_name, *, namespace, parameter_overrides), one names itself, as rclpy's tutorials do.
RCLPY_NODES = """\
    from servolab.rclpy.node import Node


    class Talker(Node):
        def __init__(self, node_name="minimal_publisher", *, namespace=None,
                     parameter_overrides=None):
            super().__init__(node_name, namespace=namespace,
                             parameter_overrides=parameter_overrides)
            self.count = self.declare_parameter("count", 0).value
            self.sent = 0
            self.publisher = self.create_publisher("std_msgs/msg/String", "chatter", 10)
            self.create_timer(0.02, self.tick)

        def tick(self):
            if self.sent >= self.count:
                return
            self.sent += 1
            self.publisher.publish(self.message("std_msgs/msg/String", data=f"hi {self.sent}"))
            self.get_logger().info(f"said hi {self.sent}")
            if self.sent == self.count:
                self.context.shutdown()


    class MinimalSubscriber(Node):
        def __init__(self):
            super().__init__("minimal_subscriber")
            self.create_subscription("std_msgs/msg/String", "chatter", self.heard, 10)

        def heard(self, msg):
            self.get_logger().info(f"heard {msg.data}")


    class NeedsARobot(Node):
        def __init__(self, robot, node_name):
            super().__init__(node_name)
"""


@pytest.fixture
def rclpy_nodes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    (tmp_path / "rclpy_nodes.py").write_text(textwrap.dedent(RCLPY_NODES))
    monkeypatch.syspath_prepend(str(tmp_path))
    return "rclpy_nodes"


def test_rclpy_shaped_node_classes_run_with_the_entrys_name_namespace_and_parameters(
        tmp_path: Path, rclpy_nodes: str) -> None:
    """D5: a class taking rclpy's ``Node.__init__(node_name, *, namespace=...,
    parameter_overrides=...)`` runs, and so does one that names itself; the launch file's
    name, namespace and parameters win, as ros2 launch's do."""
    path = write(tmp_path, f"""\
        nodes:
          - name: talker
            node: {rclpy_nodes}:Talker
            namespace: /robot
            parameters: {{count: 3}}
            required: true
          - {{name: listener, node: {rclpy_nodes}:MinimalSubscriber, namespace: /robot}}
        """)
    lines: list[str] = []
    assert run_launch(load_launch(path), out=lines.append) == 0
    assert [line for line in lines if line.startswith("[/robot/talker]")] == [
        f"[/robot/talker] INFO said hi {k}" for k in (1, 2, 3)]
    heard = [line for line in lines if line.startswith("[/robot/listener]")]
    assert heard and heard == [f"[/robot/listener] INFO heard hi {k}"
                               for k in range(1, len(heard) + 1)]


def test_a_node_class_a_launch_cannot_build_is_refused_before_anything_starts(
        tmp_path: Path, rclpy_nodes: str) -> None:
    path = write(tmp_path, f"""\
        nodes:
          - name: a
            node: {rclpy_nodes}:NeedsARobot
        """)
    with pytest.raises(LaunchError) as caught:
        run_launch(load_launch(path), out=lambda _: None)
    message = str(caught.value)
    assert message.startswith(f"{path}:3: node 'a': key 'node': {rclpy_nodes}:NeedsARobot "
                              "cannot be built by a launch file: missing a required argument: "
                              "'node_name' (a node class takes (context, name, namespace, "
                              "...) as servolab's, or (node_name, *, namespace=...) as "
                              "rclpy's)")
    assert "\n" not in message


#: rclpy-shaped programs on servolab.rclpy's default context, which opens the transport the
#: environment names: what an exec entry of a Zenoh launch must be given to meet the others.
EXEC_TALKER = """\
    from servolab import rclpy
    from servolab.rclpy.node import Node
    rclpy.init()
    node = Node("exec_talker")
    pub = node.create_publisher("std_msgs/msg/String", "/chatter", 10)
    node.create_timer(0.05, lambda: pub.publish(node.message("std_msgs/msg/String", data="hi")))
    rclpy.spin(node)
"""
EXEC_LISTENER = """\
    import sys, time
    from servolab import rclpy
    from servolab.rclpy.node import Node
    rclpy.init()
    node = Node("exec_listener")
    heard = []
    node.create_subscription("std_msgs/msg/String", "/chatter", heard.append, 10)
    deadline = time.monotonic() + 30
    while len(heard) < 9 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.1)
    print(f"heard {len(heard)}", flush=True)
    rclpy.shutdown()
    sys.exit(0 if len(heard) >= 9 else 3)
"""


@pytest.mark.slow
@pytest.mark.parametrize(("transport", "talker"),
                         [("zenoh", "exec"), ("zenoh", "node"), ("dds", "exec"), ("dds", "node")])
def test_exec_entries_of_a_launch_meet_its_other_processes(
        tmp_path: Path, transport: str, talker: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """D5: an exec entry inherits the launch's transport (SERVOLAB_TRANSPORT, its endpoints,
    ROS_DOMAIN_ID), so an rclpy-shaped listener hears a talker that is another exec entry
    (no node group: the first exec entry is where the others meet) or a node group. Over DDS
    in the domain ROS_DOMAIN_ID names (a free one here)."""
    from tests.rosoracle import free_domain_id

    monkeypatch.setenv("ROS_DOMAIN_ID", str(free_domain_id()))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    entry = (f"{{name: talker, exec: {script(EXEC_TALKER)}}}" if talker == "exec" else
             f"{{name: talker, node: {DEMO}:Talker, parameters: {{rate: 20.0}}}}")
    topic = "/chatter" if talker == "exec" else "/cmd_vel"
    listener = EXEC_LISTENER.replace("std_msgs/msg/String", "geometry_msgs/msg/Twist") \
        .replace("/chatter", topic) if talker == "node" else EXEC_LISTENER
    path = write(tmp_path, f"""\
        transport: {transport}
        nodes:
          - {entry}
          - name: listener
            exec: {script(listener)}
            required: true
        """)
    lines: list[str] = []
    assert run_launch(load_launch(path), out=lines.append, stop_timeout=10) == 0, lines
    assert "[listener] heard 9" in lines
    assert not any(alive(pid) for pid in started_pids(lines).values())


def test_exec_children_are_given_the_launchs_transport_in_their_environment() -> None:
    options = TransportOptions("zenoh", ["tcp/127.0.0.1:0"], ["tcp/127.0.0.1:7000"], 7)
    assert child_environment(options) == {
        "SERVOLAB_TRANSPORT": "zenoh", "SERVOLAB_LISTEN": "tcp/127.0.0.1:0",
        "SERVOLAB_CONNECT": "tcp/127.0.0.1:7000", "ROS_DOMAIN_ID": "7"}
    assert child_environment(TransportOptions())["SERVOLAB_TRANSPORT"] == "local"


def test_a_launch_of_rclpy_shaped_classes_leaves_no_default_context_open(
        tmp_path: Path, rclpy_nodes: str) -> None:
    """The classes' own rclpy-shaped ``__init__`` runs before the launch's and asked for the
    process's default context, which stayed open after the launch (and broke the next
    ``rclpy.init()`` in the same process)."""
    from servolab.middleware import default_context

    path = write(tmp_path, f"""\
        nodes:
          - name: talker
            node: {rclpy_nodes}:Talker
            parameters: {{count: 2}}
            required: true
        """)
    default_context.shutdown()  # what an earlier test in this process may have left open
    assert not default_context.is_initialized()
    assert run_launch(load_launch(path), out=lambda _: None) == 0
    assert not default_context.is_initialized()
