"""A message that finds the executor idle runs on the thread that received it
(``run_on_arrival``, :meth:`Executor.run_if_idle`), and callbacks still run one at a time.

Why a subscription would ask: the thread wake-up from Zenoh's inbox watcher to the spinning
thread is the one hop servolab has and bare Zenoh has not (``benchmarks/wakeups.py``).
What must not change: rclpy's single-threaded executor runs one callback at a time
(rclpy/executors.py, ``SingleThreadedExecutor``), so while a callback runs on the receiving
thread the spinner runs nothing, and what the callback raises reaches the one who spins."""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from typing import Any

import pytest

from servolab.clock import VirtualClock, WallClock
from servolab.middleware.context import Context
from servolab.middleware.executor import Executor
from servolab.middleware.node import Node
from tests.waiting import wait_until

TWIST = "geometry_msgs/msg/Twist"


@pytest.fixture
def executor() -> Iterator[Executor]:
    """An executor spun on its own thread until the test ends."""
    executor = Executor(WallClock())
    spinner = executor.spin_in_thread()
    yield executor
    executor.shutdown()
    spinner.join(5)


def wait_asleep(executor: Executor) -> None:
    """Until the spinner sleeps with nothing to do (what run_if_idle asks)."""
    done = threading.Event()
    executor.submit(done.set)
    assert done.wait(5)
    assert wait_until(lambda: executor._sleepers == 1), "the spinner never went to sleep"


def run_when_idle(executor: Executor, work: Any) -> None:
    """``run_if_idle(work)`` until the executor takes it: the spinner looks up from its sleep
    now and then (spin's 0.1 s), and a call in that moment is refused."""
    assert wait_until(lambda: executor.run_if_idle(work)), "the executor was never idle"


def in_function(thread: threading.Thread, name: str) -> bool:
    """Whether ``thread`` is inside a function called ``name`` now (its stack, read with
    sys._current_frames)."""
    frame = sys._current_frames().get(thread.ident or 0)
    while frame is not None:
        if frame.f_code.co_name == name:
            return True
        frame = frame.f_back
    return False


def test_work_runs_on_the_calling_thread_when_the_executor_is_idle(
        executor: Executor) -> None:
    wait_asleep(executor)
    ran_on: list[int] = []
    run_when_idle(executor, lambda: ran_on.append(threading.get_ident()))
    assert ran_on == [threading.get_ident()]


def test_while_it_runs_the_spinner_runs_nothing(executor: Executor) -> None:
    wait_asleep(executor)
    release, started, later = threading.Event(), threading.Event(), threading.Event()
    order: list[str] = []

    def slow() -> None:
        started.set()
        executor.submit(lambda: (order.append("queued"), later.set()))
        assert not later.wait(0.3), "the spinner ran work while a callback ran elsewhere"
        order.append("idle run ends")
        release.wait(5)

    runner = threading.Thread(target=run_when_idle, args=(executor, slow))
    runner.start()
    assert started.wait(5)
    release.set()
    runner.join(5)
    assert later.wait(5)
    assert order == ["idle run ends", "queued"]


def test_it_is_refused_when_the_executor_is_not_idle() -> None:
    ran: list[str] = []
    executor = Executor(WallClock())
    assert not executor.run_if_idle(lambda: ran.append("no spinner"))
    spinner = executor.spin_in_thread()
    try:
        wait_asleep(executor)
        gate = threading.Event()
        executor.submit(gate.wait)  # the spinner is busy
        assert not executor.run_if_idle(lambda: ran.append("busy spinner"))
        gate.set()
        wait_asleep(executor)
        # from the spinner's own thread (a callback's publish) it is the spinner's work
        inside = threading.Event()
        executor.submit(lambda: (executor.run_if_idle(lambda: ran.append("spinner's own")),
                                 inside.set()))
        assert inside.wait(5)
    finally:
        executor.shutdown()
        spinner.join(5)
    assert ran == []
    virtual = Executor(VirtualClock())
    assert not virtual.run_if_idle(lambda: ran.append("virtual"))  # time moves by the spinner
    assert ran == []


def test_what_it_raises_reaches_the_spinner_and_spin_until_sees_what_it_did() -> None:
    executor = Executor(WallClock())
    done = threading.Event()
    results: list[Any] = []

    def spin() -> None:
        try:
            results.append(executor.spin_until(done.is_set, timeout=10))
        except RuntimeError as error:
            results.append(error)

    spinner = threading.Thread(target=spin)
    spinner.start()
    try:
        assert wait_until(lambda: executor._sleepers == 1)  # asleep in spin_until
        # the condition met by a run on another thread: spin_until returns without waiting
        # for its timeout (the run's end wakes it)
        run_when_idle(executor, done.set)
        spinner.join(5)
        assert results == [True]
        done.clear()
        spinner = threading.Thread(target=spin)
        spinner.start()
        assert wait_until(lambda: executor._sleepers == 1)

        def fails() -> None:
            raise RuntimeError("a callback failed on the receiving thread")

        run_when_idle(executor, fails)  # not raised here: the spinner's
        spinner.join(5)
        assert [str(r) for r in results[1:]] == ["a callback failed on the receiving thread"]
    finally:
        executor.shutdown()
        spinner.join(5)


def rclpy_style_spinner(executor: Executor, raised: list[str]) -> threading.Thread:
    """A thread spinning ``executor`` as rclpy's executors do (inside ``spinning()``), noting
    the error that ends its spin."""
    def spin() -> None:
        with executor.spinning():
            try:
                executor.spin()
            except RuntimeError as error:
                raised.append(str(error))

    spinner = threading.Thread(target=spin)
    spinner.start()
    return spinner


def test_what_it_raises_comes_out_of_a_spin_as_rclpy_spins() -> None:
    """rclpy's executors spin inside ``spinning()`` (servolab.rclpy.executors), where a spin
    thread's stored error is never raised: the idle run's error is raised by the spinner as
    if it had run the callback itself."""
    executor = Executor(WallClock())
    raised: list[str] = []
    spinner = rclpy_style_spinner(executor, raised)
    try:
        assert wait_until(lambda: executor._sleepers == 1)

        def fails() -> None:
            raise RuntimeError("failed on the receiving thread")

        run_when_idle(executor, fails)
        spinner.join(5)
        assert raised == ["failed on the receiving thread"]
    finally:
        executor.shutdown()
        spinner.join(5)


def test_a_shutdown_inside_it_does_not_wait_for_the_spinner_that_waits_for_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """``Context.close`` from a callback (a node ending its run) shuts the executor down:
    joining the spin thread there would wait out its timeout, since that thread waits for
    the callback."""
    executor = Executor(WallClock())
    spinner = executor.spin_in_thread()
    joined: list[threading.Thread] = []
    join = threading.Thread.join

    def recorded_join(thread: threading.Thread, timeout: float | None = None) -> None:
        joined.append(thread)
        join(thread, timeout)

    try:
        wait_asleep(executor)
        monkeypatch.setattr(threading.Thread, "join", recorded_join)
        run_when_idle(executor, executor.shutdown)
        assert spinner not in joined
    finally:
        monkeypatch.undo()
        executor.shutdown()
        spinner.join(5)
    assert not spinner.is_alive()


def test_its_error_is_the_sleeping_spinners_not_another_waiters() -> None:
    """A thread that spins once without being counted as spinning (rclpy's
    spin_until_future_complete from another thread) is not given the error of a callback it
    did not run: the spinner asleep when the run began is."""
    executor = Executor(WallClock())
    raised: list[str] = []
    spinner = rclpy_style_spinner(executor, raised)
    other_result: list[Any] = []
    try:
        assert wait_until(lambda: executor._sleepers == 1)

        def fails() -> None:
            other = threading.Thread(target=lambda: other_result.append(
                executor.spin_once(0.5)))
            other.start()
            other_ready.append(other)
            # until the other thread waits in the executor while this callback runs
            assert wait_until(lambda: in_function(other, "_next_work"))
            raise RuntimeError("failed on the receiving thread")

        other_ready: list[threading.Thread] = []
        run_when_idle(executor, fails)
        spinner.join(5)
        other_ready[0].join(5)
        assert raised == ["failed on the receiving thread"]
        assert other_result == [False]
    finally:
        executor.shutdown()
        spinner.join(5)


def test_over_zenoh_the_callback_runs_on_the_watcher_only_when_asked(
        zenoh_pair: tuple[Context, Context, int]) -> None:
    """The subscription that asks has its callback on the inbox watcher's thread (named
    ``servolab-inbox <topic>``) while the executor idles; the one that does not, on the
    spinning thread, as before."""
    a, b, _ = zenoh_pair
    talker = Node(a, "talker")
    listener = Node(b, "listener")
    threads: dict[str, list[str]] = {"asked": [], "not asked": []}
    listener.create_subscription(TWIST, "/on_arrival", lambda _m: threads["asked"].append(
        threading.current_thread().name), 10, run_on_arrival=True)
    listener.create_subscription(TWIST, "/as_before", lambda _m: threads["not asked"].append(
        threading.current_thread().name), 10)
    fast, plain = (talker.create_publisher(TWIST, topic, 10)
                   for topic in ("/on_arrival", "/as_before"))
    assert fast.wait_for_subscription(10) and plain.wait_for_subscription(10)
    spinner = b.executor.spin_in_thread()
    try:
        for n in range(1, 6):  # one at a time, each finding the executor idle
            for publisher, heard in ((fast, threads["asked"]), (plain, threads["not asked"])):
                wait_asleep(b.executor)
                publisher.publish(talker.message(TWIST))
                # waited for, not spun for: a second spinner would make it not idle
                assert wait_until(lambda n=n, heard=heard: len(heard) >= n), threads
    finally:
        b.executor.shutdown()
        spinner.join(5)
    # a message that finds the executor busy (Zenoh's own graph work may be there) waits for
    # the spinner as any other: most, not all, found it idle
    on_watcher = [name for name in threads["asked"] if name == "servolab-inbox /on_arrival"]
    assert len(on_watcher) >= 3, threads
    assert set(threads["not asked"]) == {spinner.name}, threads
