"""Work off the GUI thread: one worker thread per page, one slot per kind of job.

A new request of a kind replaces the one still waiting and cancels the one running (a drag sends
many; only the latest matters) — unless it is submitted with ``keep_running``: then the running
one finishes and is delivered (a solve that cannot stop part-way is not thrown away). Jobs report progress through :class:`Progress`, which also raises
:class:`Cancelled` at the job's next checkpoint once it is cancelled; a cancelled job's result is
never delivered. Errors a user can act on (:class:`~mjmotion.errors.MjmotionError`) and bugs are
both reported to the page; the worker keeps running.
"""

from __future__ import annotations

import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..errors import MjmotionError


class Cancelled(Exception):
    """Raised inside a job at a checkpoint after it was cancelled."""


@dataclass
class Job:
    kind: str
    run: Callable[[Progress], Any]
    done: Callable[[Any], None]
    label: str = ""
    cancelled: threading.Event = field(default_factory=threading.Event)
    submitted: float = field(default_factory=time.perf_counter)


class Progress:
    """Given to a job: ``progress(fraction, text)`` reports and is a cancel checkpoint."""

    def __init__(self, job: Job, report: Callable[[Job, float, str], None]):
        self._job, self._report = job, report

    def __call__(self, fraction: float, text: str = "") -> None:
        self.check()
        self._report(self._job, float(fraction), text)

    def check(self) -> None:
        if self._job.cancelled.is_set():
            raise Cancelled(self._job.kind)


class Worker:
    """The page's worker thread.

    Args:
        on_progress: ``(job, fraction, text)`` while a job runs (fraction 1.0 when it ends).
        on_error: ``(job, message)`` when a job fails.
    """

    def __init__(self, on_progress: Callable[[Job, float, str], None], on_error: Callable[[Job, str], None]):
        self._on_progress, self._on_error = on_progress, on_error
        self._pending: dict[str, Job] = {}
        self._running: Job | None = None
        self._cv = threading.Condition()
        self._stop = False
        self._thread = threading.Thread(target=self._loop, name="studio-worker", daemon=True)
        self._thread.start()

    def submit(self, kind: str, run: Callable[[Progress], Any], done: Callable[[Any], None], label: str = "", keep_running: bool = False) -> Job:
        """Queue ``run(progress)``; ``done(result)`` is called on the worker thread when it succeeds.

        A waiting job of ``kind`` is dropped; a running one is cancelled unless ``keep_running``.
        """
        job = Job(kind, run, done, label or kind)
        with self._cv:
            old = self._pending.pop(kind, None)
            if old is not None:
                old.cancelled.set()
            if self._running is not None and self._running.kind == kind and not keep_running:
                self._running.cancelled.set()
            self._pending[kind] = job
            self._cv.notify()
        return job

    def cancel(self, kind: str | None = None) -> None:
        """Cancel waiting and running jobs (of ``kind``, or all)."""
        with self._cv:
            for k in [k for k in self._pending if kind is None or k == kind]:
                self._pending.pop(k).cancelled.set()
            if self._running is not None and (kind is None or self._running.kind == kind):
                self._running.cancelled.set()

    @property
    def busy(self) -> bool:
        with self._cv:
            return self._running is not None or bool(self._pending)

    def wait_idle(self, timeout: float = 60.0) -> bool:
        """Block until nothing is waiting or running (tests, screenshots); ``False`` on timeout."""
        end = time.monotonic() + timeout
        with self._cv:
            while self._running is not None or self._pending:
                left = end - time.monotonic()
                if left <= 0:
                    return False
                self._cv.wait(min(left, 0.1))
        return True

    def stop(self, timeout: float = 5.0) -> None:
        self.cancel()
        with self._cv:
            self._stop = True
            self._cv.notify_all()
        self._thread.join(timeout)

    def _loop(self) -> None:
        while True:
            with self._cv:
                while not self._pending and not self._stop:
                    self._cv.wait()
                if self._stop:
                    return
                kind = next(iter(self._pending))
                job = self._pending.pop(kind)
                self._running = job
            try:
                result = job.run(Progress(job, self._on_progress))
                if not job.cancelled.is_set():
                    job.done(result)
            except Cancelled:
                pass
            except MjmotionError as e:
                if not job.cancelled.is_set():
                    self._on_error(job, str(e))
            except Exception as e:  # a bug: reported in the page, the app keeps serving
                traceback.print_exc()
                if not job.cancelled.is_set():
                    self._on_error(job, f"internal error: {type(e).__name__}: {e}")
            finally:
                with self._cv:
                    self._running = None
                    self._cv.notify_all()
                self._on_progress(job, 1.0, "")
