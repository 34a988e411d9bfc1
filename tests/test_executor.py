"""The executor: every backend streams one outcome per key; Dask retries, survives a killed worker
and enforces the time limit (tasks are module functions: forked workers import this module)."""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mjmotion import executor
from mjmotion.errors import MjmotionError


def square(i: int) -> int:
    return i * i


def mixed(i: int, log: str | None = None) -> int:
    """0..: squares; 3: bad input; 4: a bug (each attempt logged)."""
    if log is not None:
        with open(log, "a") as f:
            f.write(f"{i}\n")
    if i == 3:
        raise MjmotionError(f"clip {i}: bad input")
    if i == 4:
        raise ValueError(f"bug on {i}")
    return i * i


def die_once(i: int, marker: str) -> int:
    """The first attempt of task 2 kills its own worker process (as the OOM killer would)."""
    if i == 2 and not os.path.exists(marker):
        Path(marker).write_text(str(os.getpid()))
        os.kill(os.getpid(), signal.SIGKILL)
    return i * i


def slow(i: int, seconds: float = 120.0) -> int:
    if i == 1:
        time.sleep(seconds)
    return i * i


#: Set by :func:`warm` in the process that starts the cluster; forked workers inherit it.
WARMED: int | None = None


def warm() -> None:
    global WARMED
    WARMED = os.getpid()


def warmed() -> tuple[int | None, int]:
    """On a worker: the pid that ran :func:`warm` before forking it, and the worker's parent."""
    return WARMED, os.getppid()


@pytest.fixture(scope="module")
def dask2():
    ex = executor.start(workers=2, preload=("json", warm))
    yield ex
    ex.close()


def _check_mixed(outs: list[executor.Outcome], n: int) -> dict:
    by = {o.key: o for o in outs}
    assert sorted(by) == list(range(n)) and len(outs) == n  # every key exactly once
    for i in range(n):
        if i == 3:
            assert by[i].kind == "input" and by[i].error == "clip 3: bad input" and by[i].value is None
        elif i == 4:
            assert by[i].kind == "internal" and "ValueError: bug on 4" in by[i].error
            with pytest.raises(ValueError, match="bug on 4"):
                by[i].unwrap()
        else:
            assert by[i].ok and by[i].value == i * i and by[i].unwrap() == i * i
    return by


@pytest.mark.parametrize("jobs", [1, 2])
def test_serial_and_process_pool_stream_every_outcome(jobs):
    with executor.start(jobs=jobs) as ex:
        assert ex.kind == ("serial" if jobs == 1 else "process pool")
        _check_mixed(list(ex.run(mixed, [(i, (i,)) for i in range(6)], progress=False)), 6)
        with pytest.raises(MjmotionError, match="needs Dask"):
            list(ex.run(square, [(0, (0,))], timeout=1.0, progress=False))


def test_dask_outcomes_and_retries(dask2, tmp_path):
    log = tmp_path / "attempts.txt"
    outs = list(dask2.run(mixed, [(i, (i, str(log))) for i in range(6)], retries=2, progress=False))
    _check_mixed(outs, 6)
    attempts = log.read_text().split()
    assert attempts.count("4") == 3  # the bug: the first run and two retries by Dask
    assert attempts.count("3") == 1  # bad input is not retried
    assert dask2.workers == 2 and (dask2.dashboard is None or dask2.dashboard.startswith("http://127.0.0.1:"))


@pytest.mark.parametrize("gone", [True, False])
def test_a_result_that_cannot_be_fetched_is_the_schedulers_end_or_one_row(dask2, monkeypatch, gone):
    """The CI run that saw the scheduler killed between a task's end and the fetch of its result
    failed with Dask's CommClosedError and its traceback. Such a fetch is now the scheduler going
    away when the client notices it has (the run's one error), else that task's "worker" row."""
    from distributed import Future
    from distributed.comm.core import CommClosedError

    real = Future.result

    def result(self, *a, **k):
        if self.key.endswith("-2"):
            raise CommClosedError("in <TCP (closed) ConnectionPool.gather>: Stream is closed")
        return real(self, *a, **k)

    monkeypatch.setattr(Future, "result", result)
    monkeypatch.setattr(dask2, "_gone", lambda wait: gone)
    tasks = [(i, (i,)) for i in range(4)]
    if gone:
        with pytest.raises(MjmotionError, match=r"the Dask scheduler at .* went away \(connection lost\); \d of 4 tasks had finished"):
            list(dask2.run(square, tasks, progress=False))
        return
    by = {o.key: o for o in dask2.run(square, tasks, progress=False)}
    assert sorted(by) == [0, 1, 2, 3] and by[2].kind == "worker" and "could not be fetched (in <TCP" in by[2].error
    assert [by[i].value for i in (0, 1, 3)] == [0, 1, 9]


@pytest.mark.parametrize("gone", [True, False])
def test_a_scheduler_that_stops_answering_the_poll_ends_the_run_with_one_error(dask2, monkeypatch, gone):
    """The CI run that saw its scheduler killed just before the run's twice-a-second look at the cluster
    failed with Dask's OSError ("Timed out trying to connect ... after 10 s") and its traceback. It is
    now the scheduler going away when the client notices it has, else one error that it stopped answering,
    and a client that can no longer cancel the tasks left does not put its own traceback over it."""
    from distributed.comm.core import CommClosedError

    real, calls = dask2.client.nthreads, []

    def nthreads(*a, **k):  # (the run's first call, as it starts, answers)
        calls.append(1)
        if len(calls) > 1:
            raise CommClosedError("in <TCPConnector>: ConnectionRefusedError: [Errno 111] Connection refused")
        return real(*a, **k)

    def cancel(*a, **k):  # (a client that gave up on its scheduler is closed, and says so)
        from distributed.client import ClosedClientError

        raise ClosedClientError("the client is closed")

    monkeypatch.setattr(dask2.client, "nthreads", nthreads)
    monkeypatch.setattr(dask2.client, "cancel", cancel)
    monkeypatch.setattr(dask2, "_gone", lambda wait: gone)
    what = r"went away \(connection lost\)" if gone else r"stopped answering \(in <TCPConnector>: ConnectionRefusedError"
    with pytest.raises(MjmotionError, match=rf"the Dask scheduler at .* {what}.*; \d of 4 tasks had finished"):
        list(dask2.run(time.sleep, [(i, (0.4,)) for i in range(4)], progress=False))


def test_dask_worker_killed_mid_task_is_retried(dask2, tmp_path):
    marker = tmp_path / "killed"
    outs = list(dask2.run(die_once, [(i, (i, str(marker))) for i in range(8)], progress=False))
    assert marker.exists()  # a worker really died in task 2
    assert sorted(o.key for o in outs) == list(range(8))
    assert all(o.ok and o.value == o.key**2 for o in outs), [o for o in outs if not o.ok]
    # Its replacement was forked from this process like the first ones, the preload already run.
    dask2.client.wait_for_workers(2, timeout=60)
    seen = dask2.client.run(warmed)
    assert int(marker.read_text()) not in dask2.client.run(os.getpid).values()
    assert len(seen) == 2 and set(seen.values()) == {(os.getpid(), os.getpid())}, seen


def kills_its_worker(i: int) -> int:
    """Task 0 ends its worker process every time it runs (a clip that runs it out of memory)."""
    if i == 0:
        os.kill(os.getpid(), signal.SIGKILL)
    return i * i


def test_only_the_clip_that_kills_its_worker_is_blamed():
    """A one-thread worker was sent two tasks at once (worker saturation 1.1): the clip queued behind one
    that killed the worker every time was reported as killing it too."""
    with executor.start(workers=1) as ex:
        by = {o.key: o for o in ex.run(kills_its_worker, [(i, (i,)) for i in range(4)], progress=False)}
    assert sorted(by) == [0, 1, 2, 3] and by[0].kind == "worker", by[0]
    assert all(by[i].ok and by[i].value == i * i for i in (1, 2, 3)), by


def death_signal() -> int:
    """On a worker: the signal Linux sends it when the process that started it dies (0: none)."""
    import ctypes

    sig = ctypes.c_int(0)
    ctypes.CDLL(None).prctl(2, ctypes.byref(sig))  # PR_GET_PDEATHSIG
    return sig.value


def test_local_workers_end_with_the_audit_that_started_them(tmp_path, dask2):
    """After a kill -9 of an audit, its forked workers could compute on for good: Dask watches a pipe from
    the parent, and two workers forked at once can each hold the other's copy of it. They are told to end
    with their parent (a death signal, which every worker of a LocalCluster has), and do."""
    assert set(dask2.client.run(death_signal).values()) == {signal.SIGTERM}
    import psutil

    from mjmotion import bvh, synth

    root = tmp_path / "clips"
    root.mkdir()
    walk = synth.walk(seconds=20.0).motion
    for i in range(8):  # enough work that the audit is still running when it is killed
        bvh.write(walk, root / f"walk{i}.bvh")
    proc = subprocess.Popen(
        [sys.executable, "-m", "mjmotion.cli", "audit", str(root), "-o", str(tmp_path / "out"), "--workers", "2"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True,
    )  # fmt: skip
    pids: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(pids) < 3 and proc.poll() is None and time.monotonic() < deadline:  # the side process and 2 workers
            with contextlib.suppress(psutil.NoSuchProcess):
                pids = [c.pid for c in psutil.Process(proc.pid).children()]
            time.sleep(0.05)
        time.sleep(0.5)  # (the workers at work)
    finally:
        proc.kill()
        proc.wait(30)
    assert len(pids) >= 3, pids
    deadline = time.monotonic() + 30
    alive = pids
    while alive and time.monotonic() < deadline:
        alive = [p for p in pids if psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE]
        time.sleep(0.1)
    for p in alive:
        with contextlib.suppress(psutil.NoSuchProcess):
            psutil.Process(p).kill()
    assert not alive, f"processes {alive} outlived the audit that started them"


def _with_meanwhile(ex: executor.Executor, n: int = 5) -> tuple[list, list]:
    """Outcomes of ``n`` squares and, for each call of ``meanwhile``, how many outcomes had been yielded
    and (on Dask) how many of the client's futures existed."""
    got: list = []
    calls: list = []

    def meanwhile() -> None:
        calls.append((len(got), len(ex.client.futures) if isinstance(ex, executor.Dask) else None))

    for o in ex.run(square, [(i, (i,)) for i in range(n)], progress=False, meanwhile=meanwhile):
        got.append(o)
    return got, calls


def test_meanwhile_runs_once_after_every_task_is_sent(dask2):
    for ex in (executor.Executor(), executor.start(jobs=2), dask2):
        with contextlib.ExitStack() as stack:
            if ex is not dask2:
                stack.enter_context(ex)
            got, calls = _with_meanwhile(ex)
        assert sorted(o.value for o in got) == [0, 1, 4, 9, 16]
        assert len(calls) == 1 and calls[0][0] == 0, (ex.kind, calls)  # once, before any outcome
        assert calls[0][1] is None if ex is not dask2 else calls[0][1] >= 5  # with every task submitted


def test_local_settings_last_as_long_as_the_cluster():
    import dask
    import distributed  # noqa: F401  (registers Dask's "distributed." settings: the test alone read a KeyError)

    default = dask.config.get("distributed.admin.tick.interval")
    with executor.start(workers=1) as ex:
        on_worker = ex.client.run(lambda: __import__("dask").config.get("distributed.admin.tick.interval"))
        assert list(on_worker.values()) == [executor.LOCAL_CONFIG["distributed.admin.tick.interval"]]
        assert ex.dashboard is None  # not asked for
    assert dask.config.get("distributed.admin.tick.interval") == default


def test_dask_time_limit(dask2):
    start = time.perf_counter()
    outs = {o.key: o for o in dask2.run(slow, [(i, (i,)) for i in range(4)], timeout=1.0, progress=False)}
    assert time.perf_counter() - start < 60  # not the 120 s sleep
    assert outs[1].kind == "timeout" and "time limit of 1 s" in outs[1].error
    assert all(outs[i].ok and outs[i].value == i * i for i in (0, 2, 3))
    # The stuck worker was restarted: the cluster still has its two workers and runs tasks.
    dask2.client.wait_for_workers(2, timeout=60)
    assert sorted(o.value for o in dask2.run(square, [(i, (i,)) for i in range(4)], progress=False)) == [0, 1, 4, 9]


def stamped(i: int) -> tuple[float, int]:
    """Task 1 hangs; the others take 50 ms and say when they ended and in which process."""
    time.sleep(120 if i == 1 else 0.05)
    return time.time(), os.getpid()


def test_a_time_out_ends_the_stuck_worker_without_holding_the_stream(dask2):
    """Dask's nanny restart gives a stuck thread four seconds (0.8 x 5 s) before it kills the process, and
    the call held the stream: clips finished meanwhile came back 4.2 s late and the worker's slot sat idle
    (found by a review). Now the process is ended at once and its replacement takes clips."""
    lag, pids, timed_out = [], set(), []
    for o in dask2.run(stamped, [(i, (i,)) for i in range(80)], timeout=1.0, progress=False):
        if o.ok:
            lag.append(time.time() - o.value[0])
            pids.add(o.value[1])
        else:
            timed_out.append(o.key)
    assert timed_out == [1] and len(lag) == 79
    assert max(lag) < 2.0  # 4.2 s when the restart held the loop
    assert len(pids) == 2  # the worker that never hung and the successor of the one that did (its clips ran)
    dask2.client.wait_for_workers(2, timeout=60)


def test_a_task_that_overran_the_limit_between_polls_is_a_timeout(dask2):
    """A task finishing over its limit before the poll saw it running came back ok (found by a review:
    a 55 MB clip at 2 s with --timeout 1, when another clip's time-out held the loop)."""
    outs = {o.key: o for o in dask2.run(slow, [(i, (i, 0.4)) for i in range(3)], timeout=0.2, progress=False)}
    assert outs[1].kind == "timeout" and "over the time limit of 0.2 s" in outs[1].error and outs[1].value is None
    assert outs[0].ok and outs[2].ok


def test_stopping_early_cancels_the_rest(dask2):
    outs = dask2.run(slow, [(i, (i, 2.0)) for i in range(1, 3)], progress=False)
    first = next(outs)  # task 2 (task 1 sleeps)
    assert first.key == 2
    outs.close()
    deadline = time.time() + 30
    while dask2.client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)) and time.time() < deadline:
        time.sleep(0.1)
    assert dask2.client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks)) == 0


def test_options_are_checked():
    with pytest.raises(MjmotionError, match="--workers 0"):
        executor.start(workers=0)
    with pytest.raises(MjmotionError, match="--jobs -1"):
        executor.start(jobs=-1)
    with pytest.raises(MjmotionError, match="give one of them"):
        executor.start(workers=2, scheduler="tcp://127.0.0.1:8786")
    with pytest.raises(ValueError, match="unique"):
        list(executor.Executor().run(square, [(1, (1,)), (1, (2,))]))


def test_a_scheduler_that_does_not_answer_is_one_error():
    with socket.socket() as s:  # a free port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    start = time.perf_counter()
    with pytest.raises(MjmotionError, match=rf"--scheduler tcp://127.0.0.1:{port}: no Dask scheduler answered within 1 s"):
        executor.start(scheduler=f"tcp://127.0.0.1:{port}", connect_timeout=1.0)
    assert time.perf_counter() - start < 20


@contextlib.contextmanager
def _cluster(tmp_path: Path, *worker_args: str, workers: int = 1, pythonpath: tuple[str, ...] = ()):
    """A real ``dask scheduler`` and ``workers`` ``dask worker`` processes (``worker_args`` added) on
    127.0.0.1: yields the address and a function that starts one more worker."""
    import subprocess
    import sys

    from distributed import Client

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    address = f"tcp://127.0.0.1:{port}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([*pythonpath, *sys.path])}
    log = open(tmp_path / "dask.log", "w")
    dask = [sys.executable, "-m", "dask"]
    procs = [subprocess.Popen([*dask, "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"], stdout=log, stderr=log, env=env)]

    def add_worker() -> subprocess.Popen:
        worker = [*dask, "worker", address, "--nthreads", "1", "--host", "127.0.0.1", "--no-dashboard", *worker_args]
        procs.append(subprocess.Popen(worker, stdout=log, stderr=log, env=env))
        return procs[-1]

    try:
        for _ in range(workers):
            add_worker()
        with Client(address, timeout=60) as c:  # (the scheduler answers)
            if workers:
                c.wait_for_workers(workers, timeout=120)
        add_worker.scheduler = procs[0]  # type: ignore[attr-defined]  (a test may stop it)
        yield address, add_worker
    finally:
        for p in procs:
            p.send_signal(signal.SIGINT)
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except Exception:
                p.kill()
                p.wait()
        log.close()


def test_a_cluster_whose_workers_cannot_import_mjmotion_is_refused(tmp_path):
    """A worker without mjmotion died unpickling the first task and the audit waited for good: refused up
    front, naming the worker and what to install."""
    (tmp_path / "no_mjmotion.py").write_text(
        "import sys\n"
        "class Block:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] == 'mjmotion':\n"
        "            raise ImportError(f'No module named {name!r}')\n"
        "sys.meta_path.insert(0, Block())\n"
    )
    with _cluster(tmp_path, "--preload", "no_mjmotion", pythonpath=(str(tmp_path),)) as (address, _):
        with pytest.raises(
            MjmotionError,
            match=rf"--scheduler {address}: its worker tcp://127.0.0.1:\d+ cannot import mjmotion \(No module named 'mjmotion'\); install mjmotion",
        ):
            executor.start(scheduler=address)


def test_a_cluster_left_without_workers_ends_the_run(tmp_path, monkeypatch):
    """Its only worker (no nanny to bring it back) killed by a task: the run ends with an error naming the
    scheduler once it has had no worker for NO_WORKERS_WAIT, instead of waiting for good."""
    monkeypatch.setattr(executor, "NO_WORKERS_WAIT", 1.0)
    with _cluster(tmp_path, "--no-nanny") as (address, _):
        ex = executor.start(scheduler=address)
        try:
            start = time.perf_counter()
            with pytest.raises(MjmotionError, match=rf"the Dask cluster at {address}: no worker for 1 s .* 0 of 2 tasks finished"):
                list(ex.run(os._exit, [(0, (3,)), (1, (3,))], progress=False))
            assert time.perf_counter() - start < 30
        finally:
            ex.close()


def test_a_cluster_that_has_not_had_a_worker_yet_is_waited_for(tmp_path, monkeypatch):
    """An adaptive cluster may start with no worker and take a while to get one: that is no fault (its
    first worker comes 3 s in, beyond NO_WORKERS_WAIT, and the run finishes)."""
    import threading

    monkeypatch.setattr(executor, "NO_WORKERS_WAIT", 1.0)
    monkeypatch.setattr(executor, "WAIT_NOTE", 1.0)
    with _cluster(tmp_path, workers=0) as (address, add_worker):
        ex = executor.start(scheduler=address)
        try:
            later = threading.Timer(3.0, add_worker)
            later.start()
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                outs = list(ex.run(square, [(i, (i,)) for i in range(3)], progress=False))
            later.join()
            assert sorted(o.unwrap() for o in outs) == [0, 1, 4]
            assert f"note: the Dask cluster at {address} has no worker; waiting for one (Ctrl-C stops)" in err.getvalue()
        finally:
            ex.close()


def test_a_scheduler_that_goes_away_ends_the_run_with_one_error(tmp_path, capsys):
    """Its scheduler killed mid-run: the tasks still out were cancelled at once and came back as outcomes
    ("cancelled by the cluster", every one), and Dask's client printed a traceback per reconnection try."""
    import threading

    with _cluster(tmp_path) as (address, add_worker):
        ex = executor.start(scheduler=address)
        try:
            outs = []
            threading.Timer(1.5, add_worker.scheduler.kill).start()
            with pytest.raises(MjmotionError, match=rf"the Dask scheduler at {address} went away \(connection lost\); \d+ of 40 tasks had finished"):
                for o in ex.run(time.sleep, [(i, (0.1,)) for i in range(40)], progress=False):
                    outs.append(o)
            assert outs and all(o.kind is None for o in outs)
        finally:
            ex.close()
    assert "Traceback" not in capsys.readouterr().err


def test_a_stopped_worker_cannot_hold_the_start(tmp_path):
    """The check of the workers' mjmotion has the connection's deadline: a worker stopped (SIGSTOP) never
    answers, and the start waited for good."""
    from distributed import Client

    with _cluster(tmp_path, "--no-nanny", workers=0) as (address, add_worker):
        proc = add_worker()
        with Client(address, timeout=60) as c:
            c.wait_for_workers(1, timeout=120)
        proc.send_signal(signal.SIGSTOP)
        try:
            start = time.perf_counter()
            with pytest.raises(MjmotionError, match=rf"--scheduler {address}: its workers did not all answer within 2 s"):
                executor.start(scheduler=address, connect_timeout=2.0)
            assert time.perf_counter() - start < 20
        finally:
            proc.send_signal(signal.SIGCONT)


def test_plain_progress_lines_when_not_a_terminal():
    buf = io.StringIO()
    bar = executor._Progress(3, "audit", "clip", True, stream=buf, every=0.0)
    for _ in range(3):
        bar.update()
    bar.close()
    lines = buf.getvalue().splitlines()
    assert lines[0].startswith("audit: 1/3 clips, ") and lines[-1].startswith("audit: 3/3 clips, ") and "ETA" in lines[-1]
    assert len(lines) == 3  # the closing line is not repeated


def _on_a_terminal(code: str, columns: int) -> str:
    """What ``code`` writes in a child process whose standard streams are a pseudo-terminal ``columns`` wide."""
    import fcntl
    import pty
    import struct
    import subprocess
    import sys
    import termios

    main, side = pty.openpty()
    fcntl.ioctl(side, termios.TIOCSWINSZ, struct.pack("HHHH", 24 if columns else 0, columns, 0, 0))
    env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
    proc = subprocess.Popen([sys.executable, "-c", code], stdin=side, stdout=side, stderr=side, env=env)
    os.close(side)
    out = b""
    while True:
        try:
            data = os.read(main, 4096)
        except OSError:  # the child closed its end
            break
        if not data:
            break
        out += data
    proc.wait(timeout=60)
    os.close(main)
    return out.decode(errors="replace")


@pytest.mark.parametrize("columns", [100, 0])
def test_a_bar_on_a_terminal_even_one_that_reports_no_width(columns):
    """A pseudo-terminal of size 0 (some containers' ``-t``) showed nothing at all: tqdm's dynamic width was 0."""
    code = "from mjmotion.executor import _Progress\nbar = _Progress(3, 'audit', 'clip', True)\nfor _ in range(3): bar.update()\nbar.close()\n"
    shown = _on_a_terminal(code, columns)
    assert "audit: 100%" in shown and "3/3" in shown and "clip/s" in shown
    # The verbs' step bar (mjmotion.commands._progress) too: drawn, then erased at the end.
    code = "from mjmotion.commands._progress import steps\nwith steps('blend', ('read', 'write')) as step: step('read'); step('write')\n"
    assert "blend: 1/2, write" in _on_a_terminal(code, columns)


def test_in_order():
    outs = [executor.Outcome(k, k) for k in ("b", "c", "a")]
    assert [o.key for o in executor.in_order(outs, ["a", "b", "c"])] == ["a", "b", "c"]


# --- the experiments fan out on it ---------------------------------------------------------------
class Spy(executor.Executor):
    """The serial backend, recording what it was asked to run."""

    def __init__(self):
        self.calls: list[tuple] = []

    def run(self, fn, tasks, **kw):
        tasks = list(tasks)
        self.calls.append((fn, [k for k, _ in tasks]))
        return super().run(fn, tasks, **kw)


def test_physics_audit_runs_its_clips_on_the_executor(tmp_path, monkeypatch):
    from conftest import require_data

    from mjmotion.commands.evaluate import evaluate_file
    from mjmotion.experiments import physics_audit

    data = require_data()
    monkeypatch.setattr(physics_audit, "synthesized", lambda quick: {})  # only the captured clips matter here
    monkeypatch.setattr(physics_audit, "cleanup_of_blends", lambda data_dir, out_dir, cleaned=None: ([], []))
    spy = Spy()
    table = physics_audit.run(tmp_path, data, quick=True, executor=spy)
    (fn, keys), *more = spy.calls
    assert fn is evaluate_file and not more and len(keys) == len(table.rows) >= 4
    assert [r[1] for r in table.rows] == [f"{Path(k).parent.name}/{Path(k).stem}" for k in keys]  # in file order


def test_experiment_scripts_take_workers_and_scheduler(tmp_path, monkeypatch, capsys):
    from mjmotion import experiments
    from mjmotion.experiments import Table, hitpoint_grid

    seen = {}

    def fake_run(out_dir, data_dir=None, quick=False, jobs=2, executor=None):
        seen.update(jobs=jobs, executor=executor, workers=executor.workers if executor else None)
        return Table("fake", ["a"])

    monkeypatch.setattr(hitpoint_grid, "run", fake_run)
    assert experiments.script("hitpoint_grid", None, ["--bundled", "--out", str(tmp_path), "--workers", "1"]) == 0
    assert seen["executor"].kind == "dask" and seen["workers"] == 1
    assert experiments.script("hitpoint_grid", None, ["--bundled", "--out", str(tmp_path), "--jobs", "3"]) == 0
    assert seen == {"jobs": 3, "executor": None, "workers": None}
    capsys.readouterr()
    with pytest.raises(SystemExit) as refused:  # the option's own domain: argparse's one error line, exit 2
        experiments.script("hitpoint_grid", None, ["--bundled", "--out", str(tmp_path), "--workers", "0"])
    err = capsys.readouterr().err
    assert refused.value.code == 2 and "error: argument --workers: 0: expected a number of worker processes" in err and "Traceback" not in err
    # --jobs with Dask was taken and ignored (the usage shows them as alternatives)
    seen.clear()
    assert experiments.script("hitpoint_grid", None, ["--bundled", "--out", str(tmp_path), "--jobs", "2", "--workers", "1"]) == 2
    assert "error: --jobs 2 with --workers 1: --jobs is the process pool used without Dask" in capsys.readouterr().err and not seen
    assert experiments.script("hitpoint_grid", None, ["--bundled", "--out", str(tmp_path)]) == 0 and seen["jobs"] == 2


def test_the_corruption_and_variations_experiments_run_on_the_executor(tmp_path):
    """Both send their clips out through the executor they are given (one place decides how work is sent)."""
    from mjmotion.experiments import corruption, variations

    spy = Spy()
    table = corruption.run(tmp_path / "corruption", None, quick=True, executor=spy)
    (fn, keys), *more = spy.calls
    assert fn is corruption._judge and keys == ["walk", "run"] and not more and len(table.rows) == len(corruption.CORRUPTIONS)
    spy = Spy()
    table = variations.run(tmp_path / "variations", None, quick=True, executor=spy)
    (fn, keys), *more = spy.calls
    shots = variations.load_shots(None, True)
    assert fn is variations._task and not more and sorted(keys) == list(range(len(shots)))
    assert [shots[k].motion.n_frames for k in keys] == sorted((s.motion.n_frames for s in shots), reverse=True)  # longest first
    assert {r[0] for r in table.rows} == {s.name for s in shots}  # every shot's rows, in the table


def test_evaluate_folder_runs_on_the_executors_process_pool(tmp_path, monkeypatch):
    """`evaluate DIR --jobs 2` asks mjmotion.executor for its pool and gets every file's result, in file order,
    the largest file sent first; the results equal a serial run's."""
    from mjmotion import cli
    from mjmotion.commands import evaluate as cmd

    for i, seconds in enumerate((0.5, 1.0, 0.7)):
        assert cli.main(["synth", "walk", "--seconds", str(seconds), "--seed", str(i), "-o", str(tmp_path / f"w{i}.bvh")]) == 0
    (tmp_path / "bad.bvh").write_text("HIERARCHY\n")
    files = sorted(str(p) for p in tmp_path.glob("*.bvh"))
    opts = {k: v for k, v in vars(cli.build_parser(["evaluate", "x"]).parse_args(["evaluate", "x"])).items() if not k.startswith("_")}
    asked, spies = [], []

    def start(**kw):
        asked.append(kw)
        spies.append(Spy())
        return spies[-1]

    monkeypatch.setattr(executor, "start", start)
    got = cmd.evaluate_files(files, opts, 2)
    assert asked == [{"jobs": 2}] and spies[0].calls[0][0] is cmd._safe
    sizes = [os.path.getsize(files[k]) for k in spies[0].calls[0][1]]
    assert sizes == sorted(sizes, reverse=True)
    assert [r["file"] for r in got] == files and "error" in got[0] and all("error" not in r for r in got[1:])
    monkeypatch.undo()
    serial = cmd.evaluate_files(files, opts, 1)
    assert json.dumps([r.get("row") for r in got]) == json.dumps([r.get("row") for r in serial])  # NaN included


def loaded(name: str) -> tuple[int, bool]:
    """Which process this runs in, and whether ``name`` is loaded there."""
    import sys

    return os.getpid(), name in sys.modules


def test_aside_runs_in_its_own_process_with_its_preload_and_falls_back_here_when_lost():
    import sys

    before = "colorsys" in sys.modules
    with executor.Aside(preload=("colorsys",)) as aside:
        pid, has = aside.call(loaded, "colorsys")()
        assert pid != os.getpid() and has
        assert ("colorsys" in sys.modules) == before  # loaded over there, not here
        with pytest.raises(ValueError, match="invalid literal"):
            aside.call(int, "x")()  # what the function raises comes back
        os.kill(pid, signal.SIGKILL)  # lost (killed, out of memory): the work is done here instead
        assert aside.call(loaded, "json")() == (os.getpid(), True)


def _sigint_handler() -> bool:
    import signal

    return signal.getsignal(signal.SIGINT) is signal.SIG_IGN


def _sleep(seconds: float) -> float:
    time.sleep(seconds)
    return seconds


def test_a_process_pool_ignores_ctrl_c_in_its_workers_and_ends_them_on_it(ctrl_c):
    """`evaluate DIR` printed "interrupted" after Ctrl-C and then hung (4 runs in 15): the terminal's SIGINT
    reached the pool's workers too, and a worker interrupted mid-task broke the pool. The workers ignore it,
    as Dask's do, and a Ctrl-C in this process ends them rather than waiting for their clips."""
    with executor.start(jobs=2) as ex:
        assert all(o.unwrap() is True for o in ex.run(_sigint_handler, [(i, ()) for i in range(4)], progress=False))
    import threading

    started = time.perf_counter()
    ex = executor.start(jobs=2)
    threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start()  # Ctrl-C while the tasks run
    with pytest.raises(KeyboardInterrupt):
        with ex:
            for _ in ex.run(_sleep, [(0, (60.0,)), (1, (60.0,))], progress=False):
                pass
    assert time.perf_counter() - started < 30  # the 60 s tasks were not waited for
