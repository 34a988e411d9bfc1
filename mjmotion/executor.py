"""Where a batch of independent tasks runs: this process, a process pool, a Dask ``LocalCluster``, or
an existing Dask cluster. The one place that decides how work is sent out.

Every backend has the same interface; outcomes stream back as tasks finish, in any order::

    with executor.start(workers=2) as ex:          # or scheduler="tcp://host:8786", jobs=2, or nothing (serial)
        for out in ex.run(fn, [(key, args), ...], timeout=60, desc="audit", unit="clip"):
            out.key, out.ok, out.value, out.error, out.kind

``fn(*args)`` runs on a worker (a module-level function, so it pickles by reference). An
:class:`~mjmotion.errors.MjmotionError` it raises is an outcome of kind ``"input"`` with the
error's one-line message (bad input: not retried). Anything else is retried by Dask
(``Client.submit(..., retries=)``) and then becomes kind ``"internal"``; a task whose worker died
more than ``distributed.scheduler.allowed-failures`` times (killed, out of memory) is kind
``"worker"`` (Dask reschedules it before that: every key still comes back exactly once); a task that
runs longer than ``timeout`` seconds is kind ``"timeout"``: its future is cancelled and its worker
process ended, which its nanny replaces at once (a Python thread cannot be interrupted). Scheduling, retries and worker
management are Dask's; this module only streams the outcomes, enforces the time limit and shows
progress (a tqdm bar on a terminal, a plain line every few seconds otherwise).

The serial and process-pool backends have no retries and no time limit (``timeout`` is refused).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, TextIO

from .errors import MjmotionError, printable

#: Seconds to wait for ``--scheduler`` to answer.
CONNECT_TIMEOUT = 10.0
#: Dask retries of a task that raised something other than an ``MjmotionError``.
RETRIES = 1
#: Seconds between plain progress lines when standard error is not a terminal.
PLAIN_EVERY = 5.0
#: Seconds between checks of running tasks against the time limit (and of the cluster having workers).
POLL = 0.5
#: Seconds a cluster that had workers may have none before the run ends with an error (every worker lost
#: and none back: the tasks would wait for good). Generous: an adaptive cluster may take a while to start one.
NO_WORKERS_WAIT = 120.0
#: Seconds a run waits, when a finished task's result cannot be fetched, for the client to notice its
#: scheduler has gone (killed between the task's end and the fetch) before calling it the task's fault.
FETCH_WAIT = 5.0
#: Seconds without a worker before a run says it is waiting for one.
WAIT_NOTE = 10.0
#: Dask settings of a LocalCluster. The workers' statistical profiler (a stack sample every 10 ms, for the
#: dashboard) cost a quarter of the CPU time of evaluating the shared clips. The event-loop ticks (every
#: 20 ms in the scheduler, each nanny and each worker, only to notice a blocked loop), the nannies' memory
#: checks (every 100 ms) and the system monitors (every 500 ms) kept an idle two-worker cluster at 0.07 CPU
#: seconds per second, 0.015 with these intervals: about the cost of scheduling the 42 shared clips over
#: their few seconds. Our tasks are whole clips; the nanny still restarts a worker that outgrows its memory.
LOCAL_CONFIG = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.memory.monitor-interval": "500ms",
    "distributed.admin.system-monitor.interval": "2s",
    # Each local worker runs this module's dask_setup as it starts (it ignores Ctrl-C: see there).
    "distributed.worker.preload": ["mjmotion.executor"],
    # One task on a worker at a time (the default 1.1 sent a one-thread worker two): a worker that dies
    # then has only the clip it was running counted against that clip; a clip merely queued behind a
    # pathological one on the same worker was reported as killing its worker every time.
    "distributed.scheduler.worker-saturation": 1.0,
}


@dataclass(frozen=True)
class Outcome:
    """What came back for one task.

    Attributes:
        key: the key the task was submitted with.
        value: ``fn``'s return value (``None`` on error).
        error: the one-line message, ``None`` on success.
        kind: ``None`` on success, else ``"input"``, ``"internal"``, ``"worker"`` or ``"timeout"``.
        seconds: the task's run time on its worker (``nan`` when it did not finish).
        exception: the exception of an ``"internal"`` outcome (for :meth:`unwrap`).
    """

    key: Any
    value: Any = None
    error: str | None = None
    kind: str | None = None
    seconds: float = float("nan")
    exception: BaseException | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    def unwrap(self) -> Any:
        """The value, or raise: the original exception of an internal error, else an ``MjmotionError``."""
        if self.ok:
            return self.value
        if self.exception is not None:
            raise self.exception
        raise MjmotionError(self.error if self.kind == "input" else f"task {self.key}: {self.error}")


def one_line(text: str) -> str:
    """``text`` on one printable line: whitespace runs as one space, other control characters (a file
    name's terminal escapes) escaped as Python writes them, as the CLI prints its errors."""
    return printable(" ".join(str(text).split())) or "(no message)"


def _within(seconds: float, fn: Callable[[], Any]) -> Any:
    """``fn()`` run in a thread, its value if it returns within ``seconds`` (its exception raised here), else
    None: for calls into Dask that have no deadline of their own (a stopped worker never answers)."""
    import threading

    box: dict[str, Any] = {}

    def call() -> None:
        try:
            box["value"] = fn()
        except BaseException as e:
            box["error"] = e

    thread = threading.Thread(target=call, name="mjmotion-dask-call", daemon=True)
    thread.start()
    thread.join(seconds)
    if "error" in box:
        raise box["error"]
    return box.get("value")


def _connect(client_class: Any, scheduler: str, timeout: float) -> Any:
    """A Dask client of the scheduler at ``scheduler``, or one ``MjmotionError`` naming it after ``timeout``
    seconds. Dask's own ``timeout`` bounds the TCP connect only: a port that accepts and never speaks
    Dask (another server) held ``audit`` for good, so the whole start runs with a deadline (:func:`_within`)."""

    def quiet_del(self: Any) -> None:
        # A client that never connected has nothing to close: Dask's __del__ waited ~10 s for it at exit.
        if getattr(self, "status", None) == "running":
            client_class.__del__(self)

    made = type(client_class.__name__, (client_class,), {"__del__": quiet_del})
    spoke = False
    try:
        client = _within(timeout + 2.0, lambda: made(scheduler, timeout=timeout, set_as_default=False))
        why = "no Dask handshake"
    except (OSError, TimeoutError) as e:  # (asyncio's and Dask's timeouts are TimeoutErrors)
        client, why = None, type(e).__name__
    except Exception as e:  # something answered, and not as Dask does (a web server's reply read as a frame)
        client, why, spoke = None, type(e).__name__, True
    if client is not None:
        return client
    # The half-made client is abandoned; its clean-up at exit would only print a traceback.
    sys.unraisablehook = lambda _: None
    if spoke:
        raise MjmotionError(f"--scheduler {scheduler}: something answered there, not a Dask scheduler ({why} reading its reply)")
    raise MjmotionError(f"--scheduler {scheduler}: no Dask scheduler answered within {timeout:g} s ({why})")


def _call(fn: Callable[..., Any], args: tuple) -> tuple[Any, str | None, float]:
    """Runs on the worker: ``(value, input-error message, seconds)``; other exceptions propagate (Dask retries them)."""
    start = time.perf_counter()
    try:
        return fn(*args), None, time.perf_counter() - start
    except MjmotionError as e:
        return None, one_line(str(e)), time.perf_counter() - start


def _nothing() -> None:
    pass


def _internal(key: Any, e: BaseException) -> Outcome:
    return Outcome(key, error=one_line(f"internal error: {type(e).__name__}: {e}"), kind="internal", exception=e)


def _tally(futures: dict[Any, Any], done: set[Any], handling: bool = False) -> str:
    """``"K of N"``: the tasks of ``futures`` whose outcome has come back (``done``; ``handling``: less the one
    being handled, counted there though it did not finish), for a run's closing error."""
    return f"{sum(k in done for k in futures) - handling} of {len(futures)}"


def _finished(key: Any, result: tuple[Any, str | None, float]) -> Outcome:
    value, err, seconds = result
    return Outcome(key, value, err, "input" if err is not None else None, seconds)


class _Progress:
    """A tqdm bar on a terminal; otherwise a plain line every ``every`` seconds and one at the end."""

    def __init__(self, total: int, desc: str, unit: str, enabled: bool, stream: TextIO | None = None, every: float = PLAIN_EVERY):
        self.total, self.desc, self.unit, self.every = total, desc, unit, every
        self.stream = stream if stream is not None else sys.stderr
        self.enabled = enabled and total > 0
        self.done = self.shown = 0
        self.start = self.last = time.perf_counter()
        self.bar = None
        if self.enabled and self.stream.isatty():
            from tqdm import tqdm

            from .commands._progress import bar_size

            self.bar = tqdm(total=total, desc=desc, unit=unit, file=self.stream, **bar_size(self.stream))

    def update(self) -> None:
        self.done += 1
        if self.bar is not None:
            self.bar.update()
        elif self.enabled and time.perf_counter() - self.last >= self.every:
            self._line()

    def _line(self) -> None:
        from tqdm import tqdm

        self.last = time.perf_counter()
        self.shown = self.done
        dt = self.last - self.start
        rate = self.done / dt if dt > 0 else float("nan")
        eta = tqdm.format_interval((self.total - self.done) / rate) if rate > 0 else "?"
        print(f"{self.desc}: {self.done}/{self.total} {self.unit}s, {rate:.2f} {self.unit}/s, ETA {eta}", file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
        elif self.enabled and self.shown != self.done:
            self._line()


class Executor:
    """The common interface (see the module doc). Use as a context manager; :meth:`close` ends what it started."""

    kind = "serial"
    #: Worker processes (or threads in all) the backend runs tasks on.
    workers = 1
    #: The Dask dashboard's address, when one runs.
    dashboard: str | None = None

    def run(
        self,
        fn: Callable[..., Any],
        tasks: Iterable[tuple[Any, tuple]],
        *,
        timeout: float | None = None,
        retries: int = RETRIES,
        desc: str = "tasks",
        unit: str = "task",
        progress: bool = True,
        meanwhile: Callable[[], object] | None = None,
    ) -> Iterator[Outcome]:
        """Run ``fn(*args)`` for every ``(key, args)``; yield one :class:`Outcome` per key as each finishes.

        ``meanwhile()`` is called once, in this thread, as soon as every task is sent out: the caller's
        chance to prepare what it needs after the last outcome while the first tasks run (outcomes that
        finish meanwhile wait for it). Stopping early (``break``, an exception, Ctrl-C) cancels what has
        not finished.
        """
        tasks = list(tasks)
        keys = [k for k, _ in tasks]
        if len(set(keys)) != len(keys):
            raise ValueError("task keys must be unique")
        if timeout is not None and not timeout > 0:
            raise MjmotionError(f"--timeout {timeout:g}: expected a time limit in seconds > 0")
        bar = _Progress(len(tasks), desc, unit, progress)
        try:
            for out in self._run(fn, tasks, timeout, retries, meanwhile or _nothing):
                bar.update()
                yield out
        finally:
            bar.close()

    def describe(self) -> str:
        return f"{self.kind}, {self.workers} worker(s)"

    def _run(
        self, fn: Callable[..., Any], tasks: list[tuple[Any, tuple]], timeout: float | None, retries: int, meanwhile: Callable[[], object]
    ) -> Iterator[Outcome]:
        if timeout is not None:
            raise MjmotionError("a time limit needs Dask workers (--workers N or --scheduler ADDRESS)")
        meanwhile()
        for key, args in tasks:
            try:
                yield _finished(key, _call(fn, args))
            except Exception as e:
                yield _internal(key, e)

    def close(self) -> None:
        pass

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class ProcessPool(Executor):
    """``concurrent.futures.ProcessPoolExecutor`` with ``jobs`` processes."""

    kind = "process pool"

    def __init__(self, jobs: int):
        from concurrent.futures import ProcessPoolExecutor

        self.workers = jobs
        # The workers ignore Ctrl-C, as Dask's do: the terminal sends it to every process of the group, and a
        # worker interrupted mid-task broke the pool's queues, so the command printed "interrupted" and hung.
        self.pool = ProcessPoolExecutor(max_workers=jobs, initializer=_ignore_interrupt)

    def _run(
        self, fn: Callable[..., Any], tasks: list[tuple[Any, tuple]], timeout: float | None, retries: int, meanwhile: Callable[[], object]
    ) -> Iterator[Outcome]:
        from concurrent.futures import as_completed

        if timeout is not None:
            raise MjmotionError("a time limit needs Dask workers (--workers N or --scheduler ADDRESS)")
        futures = {self.pool.submit(_call, fn, args): key for key, args in tasks}
        try:
            meanwhile()
            for f in as_completed(futures):
                try:
                    yield _finished(futures[f], f.result())
                except Exception as e:
                    yield _internal(futures[f], e)
        finally:
            for f in futures:
                f.cancel()

    def close(self) -> None:
        self.pool.shutdown(wait=True, cancel_futures=True)

    def __exit__(self, *exc: object) -> None:
        if isinstance(exc[1], KeyboardInterrupt):
            # Ctrl-C: the clips running are not waited for (a long one took seconds); their processes are ended.
            for p in list((getattr(self.pool, "_processes", None) or {}).values()):
                p.terminate()
        self.close()


def _executing(dask_worker: Any) -> dict[str, float]:
    """Runs on each Dask worker's event loop: seconds each of its executing tasks has been running."""
    now = time.time()
    return {str(ts.key): now - ts.start_time for ts in list(dask_worker.state.executing) if ts.start_time}


#: The module Dask loads in a scheduler's process when its dashboard runs (it needs Bokeh).
_DASHBOARD_MODULE = "distributed.dashboard.scheduler"


@contextlib.contextmanager
def _interrupt_after() -> Iterator[None]:
    """Hold a Ctrl-C (SIGINT) until the block ends, then raise it; a second one raises at once. Only in the
    main thread (elsewhere signals cannot be handled, and the block runs as is)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held: list[int] = []

    def hold(signum: int, frame: Any) -> None:
        held.append(signum)
        if len(held) > 1:
            raise KeyboardInterrupt

    before = signal.signal(signal.SIGINT, hold)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, before)
    if held:
        raise KeyboardInterrupt


def _ignore_interrupt() -> None:
    """Ignore Ctrl-C (SIGINT) in this process, when called in its main thread (only there can it be set)."""
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)


def dask_setup(worker: Any) -> None:
    """Dask's preload hook, run in each local worker process as it starts (:data:`LOCAL_CONFIG`): Ctrl-C at
    a terminal reaches the whole process group, and every worker printed the traceback of its interrupted
    event loop under the audit's one ``error: interrupted`` line. The process that started the cluster
    takes the interrupt and closes its workers; they ignore it. A worker also ends with the process that
    started it: forked workers hold each other's copy of the pipe Dask watches for that, and after a
    ``kill -9`` of the audit they computed on for good."""
    _ignore_interrupt()
    _end_with_parent()


def _end_process() -> None:
    """Runs on a Dask worker: end its process now (its nanny starts a new one, as after a crash)."""
    import os

    os._exit(70)


class Dask(Executor):
    """A Dask ``Client``: on a new ``LocalCluster`` of ``workers`` one-thread worker processes (bound to
    127.0.0.1; its dashboard on a free port if ``dashboard``), or on the scheduler at ``scheduler``."""

    kind = "dask"

    def __init__(
        self,
        workers: int | None = None,
        scheduler: str | None = None,
        connect_timeout: float = CONNECT_TIMEOUT,
        preload: Sequence[str | Callable[[], object]] = (),
        dashboard: bool = False,
    ):
        import logging

        import dask
        from distributed import Client, LocalCluster

        # Task errors and worker deaths come back as outcomes; Dask's own log lines would bury the one-line errors.
        logging.getLogger("distributed").setLevel(logging.CRITICAL)
        # (Dask's logging settings give some of its loggers their own level: the client's printed a traceback
        # of every reconnection try once a scheduler went away.)
        for name in [n for n in logging.root.manager.loggerDict if n.startswith("distributed.")]:
            if logging.getLogger(name).level != logging.NOTSET:
                logging.getLogger(name).setLevel(logging.CRITICAL)
        self.cluster = None
        self.address = scheduler
        if scheduler is not None:
            check_address(scheduler)
            self.client = _connect(Client, scheduler, connect_timeout)
            self._deadline = connect_timeout
            try:
                self._check_workers(scheduler)
            except BaseException:
                self.client.close()
                raise
        else:
            # Workers forked from this process start in a quarter of a second with ``preload`` already
            # loaded (spawned ones take a second or more each to import Dask, NumPy and MuJoCo again).
            method = "fork" if sys.platform.startswith("linux") else "spawn"
            if method == "fork":
                load(preload)
            # Held until close: a nanny reads the start method each time it (re)starts its worker, and a
            # worker restarted after a death or a time limit should be forked, warm, like the first.
            self._settings = dask.config.set({**LOCAL_CONFIG, "distributed.worker.multiprocessing-method": method})
            try:
                # A Ctrl-C half-way through the start left Dask closing workers it had not started (printed
                # AssertionErrors): the first one waits for the cluster, a second one interrupts at once.
                with _interrupt_after():
                    # The scheduler's web server (health and metrics routes) always runs, on a free port of
                    # 127.0.0.1; the dashboard on it only when asked (Bokeh's import and its plots cost time).
                    self.cluster = LocalCluster(
                        n_workers=workers or 1, threads_per_worker=1, processes=True, host="127.0.0.1",
                        dashboard_address="127.0.0.1:0", scheduler_kwargs={"dashboard": dashboard}, silence_logs=logging.CRITICAL,
                    )  # fmt: skip
            except BaseException:
                self._settings.__exit__(None, None, None)
                raise
            self.client = Client(self.cluster, set_as_default=False)
            self.address = self.cluster.scheduler_address
        info = self.client.scheduler_info()
        self.workers = sum(int(w.get("nthreads", 1)) for w in info.get("workers", {}).values()) or (workers or 0)
        # The scheduler's web server (its "dashboard" service) also runs without a dashboard, for its health
        # routes: the dashboard is up where the scheduler runs if Dask could load it there (it needs Bokeh).
        running = "dashboard" in info.get("services", {}) and (
            _DASHBOARD_MODULE in sys.modules if self.cluster is not None else self._remote_dashboard_loaded()
        )
        self.dashboard = self.client.dashboard_link if running else None

    def _check_workers(self, scheduler: str, workers: set[str] | None = None) -> None:
        """Refuse a cluster whose workers cannot run our tasks: a worker without mjmotion died unpickling the
        first one (Dask closes it) and the audit waited for good with no worker left and no word; one with
        another version would judge with another judge. Asked with ``eval`` of constant text (a function of
        ours is sent by reference, and is what such a worker cannot load)."""
        from . import __version__

        found = _within(
            self._deadline,
            lambda: self.client.run(eval, "__import__('mjmotion').__version__", workers=sorted(workers) if workers else None, on_error="return"),
        )
        if found is None:
            raise MjmotionError(f"--scheduler {scheduler}: its workers did not all answer within {self._deadline:g} s (a worker stopped or stuck?)")
        for address, version in sorted(found.items()):
            if isinstance(version, BaseException) and not isinstance(version, ImportError):
                continue  # (gone or unreachable since it was listed: not a worker that runs tasks)
            if isinstance(version, BaseException):
                raise MjmotionError(
                    f"--scheduler {scheduler}: its worker {address} cannot import mjmotion ({one_line(str(version))}); "
                    f"install mjmotion {__version__} where the workers run (and the clips at the same paths)"
                )
            if version != __version__:
                raise MjmotionError(
                    f"--scheduler {scheduler}: its worker {address} runs mjmotion {version}, this process {__version__}; "
                    "one audit is one judge: install the same version on the workers"
                )

    def _remote_dashboard_loaded(self) -> bool:
        # Asked of the scheduler process: ``eval`` of our own constant text, because a function of ours
        # would be sent by reference and the scheduler's machine need not have mjmotion installed.
        try:
            return bool(self.client.run_on_scheduler(eval, f"{_DASHBOARD_MODULE!r} in __import__('sys').modules"))
        except Exception:  # a scheduler that refuses to run functions: no link rather than a dead one
            return False

    def describe(self) -> str:
        n = self.workers
        if self.cluster is not None:  # one thread per worker process
            return f"dask on a LocalCluster, {n} worker process{'es' if n != 1 else ''}"
        return f"dask on the scheduler at {self.address}, {n} worker thread{'s' if n != 1 else ''}"

    def _run(
        self, fn: Callable[..., Any], tasks: list[tuple[Any, tuple]], timeout: float | None, retries: int, meanwhile: Callable[[], object]
    ) -> Iterator[Outcome]:
        import uuid  # here: the CLI's start-up does not pay for it

        from distributed import KilledWorker, as_completed

        batch = uuid.uuid4().hex[:8]
        futures: dict[Any, tuple[Any, Any]] = {}  # Dask key -> (our key, its future; None once yielded)
        for i, (key, args) in enumerate(tasks):
            f = self.client.submit(_call, fn, args, key=f"mjmotion-{batch}-{i}", retries=retries, pure=False)
            futures[f.key] = (key, f)
        done: set[Any] = set()
        stream = as_completed([f for _, f in futures.values()], loop=self.client.loop)
        polled = time.perf_counter()
        # Since when the cluster has had no worker, once it had one (an adaptive cluster may start with none
        # and take minutes to get its first: that wait is not a fault).
        alone: float | None = None
        present = self.client.nthreads()
        seen, checked = bool(present), set(present)
        begun, waited = time.perf_counter(), False
        lost: list[Any] = []
        try:
            meanwhile()
            while not stream.is_empty() or lost:
                for f in [f for f in lost if f.status != "lost"]:
                    lost.remove(f)
                    stream.add(f)
                if stream.has_ready():
                    f = next(stream)
                    if f.key in done:
                        continue  # a future this loop cancelled on its time limit
                    if f.status == "lost":
                        lost.append(f)  # its result died with a worker before we fetched it: Dask computes it again
                        continue
                    done.add(f.key)
                    key = futures[f.key][0]
                    futures[f.key] = (key, None)  # drop our reference: the cluster may free the result
                    if f.status == "finished":
                        try:
                            result = f.result()
                        except OSError as closed:  # (Dask's CommClosedError): the result's connection closed under us
                            # A scheduler killed between the task's end and the fetch of its result: the same
                            # one error as when it goes away earlier (the fetch raised Dask's own traceback).
                            if self._gone(FETCH_WAIT):
                                raise self._went_away(futures, done) from None
                            yield Outcome(key, error=f"its result could not be fetched ({one_line(str(closed))})", kind="worker")
                            continue
                        if timeout is not None and result[2] > timeout:
                            # It overran the limit between two polls (or while a restart held the loop): a timeout
                            # all the same; its value is not taken (a 55 MB clip came back ok at 2 s with a 1 s limit).
                            yield Outcome(
                                key, error=f"ran {result[2]:.3g} s, over the time limit of {timeout:g} s", kind="timeout", seconds=result[2]
                            )
                            continue
                        yield _finished(key, result)
                        continue
                    e = f.exception() if f.status == "error" else None
                    if isinstance(e, KilledWorker):
                        yield Outcome(key, error="its worker died every time it ran it (killed or out of memory)", kind="worker")
                    elif e is not None:
                        yield _internal(key, e)
                    elif self.client.status != "running":
                        # The scheduler went away: every task still out is cancelled at once, which is no outcome
                        # of the clips (it made them all "worker" rows, exit 0).
                        raise self._went_away(futures, done)
                    else:
                        yield Outcome(key, error=f"cancelled by the cluster ({f.status})", kind="worker")
                    continue
                if time.perf_counter() - polled >= POLL:
                    polled = time.perf_counter()
                    # A scheduler killed since: asking it anything waits for Dask's connect timeout (10 s), then
                    # raises its OSError; the client has usually noticed by now (it cancels every future then).
                    if self.client.status != "running":
                        raise self._went_away(futures, done, handling=False)
                    try:
                        if timeout is not None:
                            yield from self._expire(futures, done, timeout)
                        present = self.client.nthreads()
                        if present and self.cluster is None and set(present) - checked:
                            self._check_workers(self.address or "", set(present) - checked)  # joined since: the same check
                            checked |= set(present)
                    except OSError as e:  # (Dask's CommClosedError, its connect timeout)
                        if self._gone(FETCH_WAIT):
                            raise self._went_away(futures, done, handling=False) from None
                        raise MjmotionError(
                            f"the Dask scheduler at {self.address} stopped answering ({one_line(str(e))}); {_tally(futures, done)} tasks had finished"
                        ) from None
                    except MjmotionError:  # (new workers that did not answer: their scheduler may be what went)
                        if self.client.status != "running":
                            raise self._went_away(futures, done, handling=False) from None
                        raise
                    if present:
                        alone, seen = None, True
                    elif alone is None and seen:
                        alone = polled
                    if not present and not waited and polled - begun > WAIT_NOTE:
                        waited = True
                        sys.stderr.write(f"note: the Dask cluster at {self.address} has no worker; waiting for one (Ctrl-C stops)\n")
                    elif alone is not None and polled - alone > NO_WORKERS_WAIT:
                        raise MjmotionError(
                            f"the Dask cluster at {self.address}: no worker for {NO_WORKERS_WAIT:g} s (every one lost and none back; their logs say why); "
                            f"{_tally(futures, done)} tasks finished"
                        )
                time.sleep(0.02)
        finally:
            pending = [f for k, (_, f) in futures.items() if k not in done and f is not None]
            # (a client that gave up on a lost scheduler is closed: cancel raised its ClosedClientError over the run's error)
            if pending and self.client.status in ("running", "connecting"):
                with contextlib.suppress(Exception):
                    self.client.cancel(pending)

    def _gone(self, wait: float) -> bool:
        """Whether the client has lost its scheduler, waiting up to ``wait`` seconds for it to notice."""
        end = time.perf_counter() + wait
        while self.client.status == "running" and time.perf_counter() < end:
            time.sleep(0.05)
        return self.client.status != "running"

    def _went_away(self, futures: dict[Any, tuple[Any, Any]], done: set[Any], handling: bool = True) -> MjmotionError:
        """The error of a run whose scheduler went away (``handling``: the future being handled is counted in
        ``done``, and did not finish)."""
        return MjmotionError(
            f"the Dask scheduler at {self.address} went away (connection lost); {_tally(futures, done, handling)} tasks had finished"
        )

    def _expire(self, futures: dict[Any, tuple[Any, Any]], done: set[Any], timeout: float) -> Iterator[Outcome]:
        """Tasks running longer than ``timeout``: an outcome each, the future cancelled, the worker process ended."""
        running = self.client.run(_executing, on_error="return")
        restart = []
        for address, since in running.items():
            if not isinstance(since, dict):
                continue  # the worker went away mid-call
            for k, elapsed in since.items():
                f = futures[k][1] if k in futures and k not in done else None
                if f is not None and elapsed > timeout and not f.done():
                    done.add(k)
                    f.cancel()
                    restart.append(address)
                    yield Outcome(futures[k][0], error=f"still running after the time limit of {timeout:g} s", kind="timeout")
        if restart:
            # A thread stuck in a task cannot be stopped: its worker process is ended and its nanny forks a new
            # one at once (the nanny's own restart first waits four seconds for the thread, holding this loop).
            # A worker without a nanny would not come back: it keeps computing but gets no more of our tasks.
            info = self.client.scheduler_info()["workers"]
            ended = sorted(a for a in set(restart) if info.get(a, {}).get("nanny"))
            if ended:
                self.client.run(_end_process, workers=ended, on_error="ignore")

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()
            self._settings.__exit__(None, None, None)


def check_address(address: str) -> None:
    """Refuse a ``--scheduler`` value that is not a Dask address before any connection (Dask would
    wait out the time limit twice on it, its client's clean-up printing a traceback)."""
    from distributed.comm import parse_address
    from distributed.comm.addressing import parse_host_port
    from distributed.comm.registry import backends

    try:
        scheme, loc = parse_address(address)
        if scheme not in backends:
            raise ValueError(f"unknown scheme {scheme!r}; Dask knows {', '.join(sorted(backends))}")
        if scheme == "inproc":
            raise ValueError("an in-process scheduler lives inside one Python process; this audit runs in its own")
        if scheme in ("tcp", "tls", "ws", "wss"):
            _, port = parse_host_port(loc)
            if not 0 < int(port) < 65536:  # (Dask takes any integer: 99999 waited out the connect timeout)
                raise ValueError(f"port {port} is not a TCP port, 1 to 65535")
    except ValueError as e:
        raise MjmotionError(f"--scheduler {address}: not a Dask scheduler address ({one_line(str(e))}); expected e.g. tcp://HOST:8786") from None


def load(preload: Iterable[str | Callable[[], object]]) -> None:
    """Import each module named in ``preload`` and call each callable (what forked workers then share)."""
    import importlib

    for item in preload:
        if callable(item):
            item()
        else:
            importlib.import_module(item)


def here(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Callable[[], Any]:
    """``fn(*args, **kwargs)`` now, in this process, with :meth:`Aside.call`'s answer: a function giving its value."""
    value = fn(*args, **kwargs)
    return lambda: value


def _aside_start(preload: Sequence[str | Callable[[], object]]) -> None:
    """The side process's first task: it ignores Ctrl-C (the process that made it handles the interrupt and
    ends it; otherwise it printed a traceback of its wait for work), then loads ``preload``."""
    _ignore_interrupt()
    _end_with_parent()
    load(preload)


def _end_with_parent() -> None:
    """Linux: this forked process gets SIGTERM when the process that made it dies (a ``kill -9`` of the
    audit left its side process waiting for work for good, holding what it inherited)."""
    import ctypes
    import os
    import signal

    try:
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # (the parent died before the call)
        os._exit(0)


class Aside:
    """One process beside the workers for this process's own serial work (the audit's histograms).

    Forked at once (before Dask is loaded: make it first), it loads ``preload`` while this process is
    still starting the cluster, on a core that is otherwise idle then: Matplotlib's import (half a second
    of CPU) no longer competes with the workers, and the drawing at the end runs beside the rest of the
    summary. Where processes are not forked (not Linux), or once the process is lost, :meth:`call` runs
    the function here instead.
    """

    def __init__(self, preload: Sequence[str | Callable[[], object]] = ()):
        self.pool: Any = None
        if sys.platform.startswith("linux"):
            import multiprocessing
            from concurrent.futures import ProcessPoolExecutor

            self.pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("fork"))
            self.pool.submit(_aside_start, tuple(preload))  # forks now (a fork pool starts its process on the first task)

    def call(self, fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Callable[[], Any]:
        """Start ``fn(*args, **kwargs)`` in the side process; returns a function that waits for its value
        (and raises what ``fn`` raised). A lost side process (killed) is not an error: ``fn`` runs here."""
        from concurrent.futures.process import BrokenProcessPool

        if self.pool is not None:
            try:
                future = self.pool.submit(fn, *args, **kwargs)
            except BrokenProcessPool:
                pass
            else:

                def wait() -> Any:
                    try:
                        return future.result()
                    except BrokenProcessPool:
                        return fn(*args, **kwargs)

                return wait
        return here(fn, *args, **kwargs)

    def close(self) -> None:
        if self.pool is not None:
            # Waits for the side process to finish what it runs (nothing, once the caller has its values): left
            # running, its pool's exit handler wrote to a closed pipe at interpreter exit (a printed OSError).
            self.pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> Aside:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


#: A LocalCluster of more worker processes than this many per core is refused: the tasks are CPU-bound, and
#: 256 workers on 2 cores started no clip in 90 s (each a forked process with its nanny and event loops).
LOCAL_PER_CORE = 4


def cores() -> int:
    """The cores this process may run on."""
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def check_options(workers: int | None = None, scheduler: str | None = None, jobs: int | None = None) -> None:
    """Refuse worker counts below 1 (or, for a LocalCluster, above :data:`LOCAL_PER_CORE` per core) and
    ``--scheduler`` with ``--workers`` (before any work)."""
    for option, n in (("--workers", workers), ("--jobs", jobs)):
        if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 1):
            raise MjmotionError(f"{option} {n}: expected a number of worker processes ≥ 1")
    if scheduler is not None and workers is not None:
        raise MjmotionError(f"--scheduler {scheduler} and --workers {workers}: the scheduler's cluster has its own workers; give one of them")
    most = max(4, LOCAL_PER_CORE * cores())
    if workers is not None and workers > most:
        raise MjmotionError(
            f"--workers {workers}: this machine has {cores()} core(s); expected at most {most} local worker processes "
            "(more only compete for the cores; a bigger cluster is reached with --scheduler)"
        )


def start(
    workers: int | None = None,
    scheduler: str | None = None,
    jobs: int | None = None,
    connect_timeout: float = CONNECT_TIMEOUT,
    preload: Sequence[str | Callable[[], object]] = (),
    dashboard: bool = False,
) -> Executor:
    """The executor the options ask for: ``scheduler`` (an existing Dask cluster), else ``workers``
    (a Dask LocalCluster of that many processes, with its dashboard if ``dashboard``), else ``jobs`` > 1
    (a process pool), else serial. ``preload``: modules the tasks need and warm-up functions, imported
    and called before local workers are forked (so they share them; a remote cluster's workers load their own)."""
    check_options(workers, scheduler, jobs)
    if scheduler is not None:
        return Dask(scheduler=scheduler, connect_timeout=connect_timeout)
    if workers is not None:
        return Dask(workers=workers, preload=preload, dashboard=dashboard)
    if jobs is not None and jobs > 1:
        return ProcessPool(jobs)
    return Executor()


def add_options(p: argparse.ArgumentParser, default: str = "") -> None:
    """``--workers N`` and ``--scheduler ADDRESS`` (the experiments and ``audit`` share them); ``default``
    says in the help what runs without them."""
    from .commands._options import integer

    p.add_argument(
        "--workers",
        type=integer(1, 4096, what="a number of worker processes"),
        metavar="N",
        help=f"run on a Dask LocalCluster of N worker processes on this machine (bound to 127.0.0.1; at most {LOCAL_PER_CORE} per core)"
        + (f" ({default})" if default else ""),
    )
    p.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing Dask cluster, e.g. tcp://HOST:8786 (started with 'dask scheduler' and 'dask worker'; "
        "its workers need mjmotion installed and the input files at the same paths)",
    )


@contextlib.contextmanager
def using(ex: Executor | None, jobs: int | None = None) -> Iterator[Executor]:
    """``ex`` as is (the caller closes it), or a new serial/process-pool executor for ``jobs``, closed after."""
    if ex is not None:
        yield ex
        return
    with start(jobs=jobs) as own:
        yield own


def in_order(outcomes: Iterable[Outcome], keys: Sequence[Any]) -> list[Outcome]:
    """Outcomes sorted back into the order of ``keys`` (for tables that list tasks as submitted)."""
    by = {o.key: o for o in outcomes}
    return [by[k] for k in keys]
