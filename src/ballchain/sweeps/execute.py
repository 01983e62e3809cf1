"""Running a sweep on dask.distributed: a LocalCluster on all cores, or an existing cluster.

Each run is one task (``run_task``): it never raises, a failure is a row with status
``error`` and its message.  The kernels are compiled once, in this process, before the
workers start (they load numba's on-disk cache); on an existing cluster each worker
loads or compiles them once, before the first task.  Rows go to the table as runs
finish (``table.TableWriter``); runs already in the table are not run again, nor are runs
this engine saved (``--save-runs``) whose rows a killed sweep never wrote.
"""

from __future__ import annotations

import math
import os
import signal
import socket
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from ..model import ParameterError
from .spec import SweepSpec, Task
from .table import TableWriter, error_row, read_table, result_row

STOP_WAIT = 120.0  # s: an interrupted sweep waits this long for its runs under way to save their checkpoints


def run_task(task: Task) -> dict:
    """Run one task and return its table row (never raises).  A run interrupted by an
    interrupted sweep (``engine.request_stop``) returns a row of status ``interrupted``,
    which the sweep does not write: its checkpoint resumes it."""
    t0 = time.perf_counter()
    where = f"{socket.gethostname()}:{os.getpid()}"
    try:
        from ..engine import simulate, stop_requested

        if stop_requested() is not None:  # the sweep is stopping: do not start
            return _interrupted_row(task)

        ck = None
        if task.checkpoint_path is not None:
            from ..methods.checkpoint import Checkpoint

            ck = Checkpoint(task.checkpoint_path, every=task.checkpoint_every)
        saved = _saved_result(task)
        if saved is not None:  # saved, but its row never written: record it, do not run it again
            if ck is not None:
                ck.discard()
            return result_row(task, saved, where)
        result = simulate(task.params, task.ic, task.options, checkpoint=ck)
        if result.status == "interrupted":
            return _interrupted_row(task)
        if task.save_path is not None:
            from ..records.files import save_result

            save_result(result, task.save_path, force=True)
        if ck is not None:
            ck.discard()  # the run has ended and its result is saved
        return result_row(task, result, where)
    except BaseException as exc:  # noqa: BLE001 - a run must never stop the sweep
        msg = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        return error_row(
            task, f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__, time.perf_counter() - t0, where
        )


def _saved_result(task: Task):
    """The run's saved file (``--save-runs``), if this engine made it from the task's inputs
    and the run ended; else None.  A sweep killed between saving a run and writing its row
    leaves such a file: the run is recorded from it, not run again.  A file that cannot be
    read (a save cut short), of other inputs or another engine, is run again and overwritten."""
    if task.save_path is None or not os.path.isfile(task.save_path):
        return None
    from ..provenance import engine_fingerprint
    from ..records.files import load_result

    try:
        r = load_result(task.save_path)
    except Exception:  # noqa: BLE001 - any unreadable file means: run again
        return None
    same = (r.params, r.ic, r.options) == (task.params, task.ic, task.options)
    if not same or r.engine != engine_fingerprint() or r.status == "interrupted":
        return None
    return r


def _interrupted_row(task: Task) -> dict:
    """The row of a run an interrupted sweep stopped (never written: ``_record``)."""
    return {"run_id": task.run_id, "status": "interrupted"}


def warm_kernels(method: str = "event") -> bool:
    """Load (or, the first time, compile) the numba kernels of ``method``
    (``engine.load_kernels``).  Returns whether they had to be compiled."""
    from ..engine import load_kernels

    return load_kernels(method)


@dataclass
class SweepReport:
    """What a sweep did: runs in the grid, already in the table, run now, failed, where."""

    table: str
    total: int
    skipped: int = 0
    ran: int = 0
    failed: int = 0
    interrupted: bool = False
    workers: int = 0
    scheduler: str = ""
    wall_seconds: float = 0.0
    statuses: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return dict(self.__dict__)


class _Stop(KeyboardInterrupt):
    pass


def _connect(scheduler: str | None, workers: int, log):
    """A dask Client: to ``scheduler``, or to a new LocalCluster of ``workers`` processes
    (one worker: a thread of this process, which starts no process, so a script that
    sweeps needs no ``if __name__ == "__main__"`` guard)."""
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="5s")
        except (OSError, TimeoutError, ValueError) as exc:
            msg = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise ParameterError(f"scheduler: cannot reach {scheduler!r} ({msg})") from None
        return client, None
    # one thread per worker process; no nested BLAS/numba threads
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    where = dict(processes=True, host="127.0.0.1") if workers > 1 else dict(processes=False)  # (in-process: inproc://)
    config = {}
    if workers <= 1:  # in this process: its loggers are ours to quiet
        logging.getLogger("distributed").setLevel(logging.ERROR)
        # A worker in this process dies only with it; the scheduler's time-to-live would
        # instead remove it when its heartbeats come late (a thread that holds the GIL
        # starves the event loop), and the result of the run it holds would be lost:
        # the sweep would wait for it forever.
        config["distributed.scheduler.worker-ttl"] = None
    with dask.config.set(config):
        cluster = LocalCluster(
            n_workers=workers, threads_per_worker=1, dashboard_address=":0", silence_logs=logging.ERROR, **where
        )
    return Client(cluster), cluster


def check_scheduler(address: str) -> None:
    """One-line error if the scheduler cannot be reached (before anything runs)."""
    client, _ = _connect(address, 0, None)
    client.close()


def run_sweep(
    spec: SweepSpec,
    out,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_errors: bool = False,
    progress: bool = True,
    log=None,
) -> SweepReport:
    """Run every task of ``spec`` that ``out`` does not hold yet; rows go to ``out``."""
    tasks = spec.tasks()  # validates everything first
    for name, where in (("save-runs", spec.save_runs), ("checkpoints", spec.checkpoints)):
        if where is not None:
            try:
                Path(where).mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise ParameterError(f"{name}: cannot create {where!r} ({exc.strerror})") from None
    return run_tasks(
        tasks, out, workers=workers, scheduler=scheduler, retry_errors=retry_errors, progress=progress, log=log
    )


def run_tasks(
    tasks: list[Task],
    out,
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    retry_errors: bool = False,
    progress: bool = True,
    log=None,
) -> SweepReport:
    """Run the ``tasks`` that the table ``out`` does not hold yet (see ``run_sweep``)."""
    log = log or sys.stderr
    t0 = time.perf_counter()
    out = Path(out)
    if out.is_dir():
        raise ParameterError(f"out: {str(out)!r} is a directory; give a file name such as sweep.parquet")
    if not out.parent.exists():
        raise ParameterError(f"out: directory {str(out.parent)!r} does not exist")
    writer = TableWriter(out, read_table(out) if out.exists() else [])
    done = {
        t.run_id
        for t in tasks
        if t.run_id in writer and not (retry_errors and writer.rows[t.run_id]["status"] == "error")
    }
    todo = [t for t in tasks if t.run_id not in done]
    workers = max(1, int(workers or os.cpu_count() or 1))
    report = SweepReport(
        table=str(out), total=len(tasks), skipped=len(done), workers=workers, scheduler=scheduler or "local"
    )
    if not todo:
        writer.flush()
        report.wall_seconds = time.perf_counter() - t0
        return _finish(report, writer, tasks)

    if scheduler is None:  # compile once here; the workers load the cache
        from ..engine import kernels_cached

        if not kernels_cached(todo[0].options.method):
            print(
                "compiling the numba kernels (first run only; a minute or two, cached afterwards)...",
                file=log,
                flush=True,
            )
        warm_kernels(todo[0].options.method)
    if progress:
        print(
            f"sweep: {len(todo)} runs to do ({len(done)} of {len(tasks)} already in {out}), "
            f"{'scheduler ' + scheduler if scheduler else f'{workers} local workers'}",
            file=log,
            flush=True,
        )

    old = {}

    def stop(signum, frame):
        raise _Stop(signal.Signals(signum).name)

    try:
        for sig in (signal.SIGINT, signal.SIGTERM):
            old[sig] = signal.signal(sig, stop)
        _run_on_cluster(todo, scheduler, workers, writer, report, progress, log)
    except _Stop as exc:
        if report.ran == len(todo):  # the signal came after the last run had ended: nothing was cut short
            print(f"\nsweep: {exc} after the last run had ended: every run is in {out}", file=log, flush=True)
        else:
            report.interrupted = True
            print(
                f"\nsweep interrupted ({exc}): {report.ran} of {len(todo)} runs done now, {len(writer.rows)} rows "
                f"in {out}; the same command finishes the rest",
                file=log,
                flush=True,
            )
    finally:
        for sig, h in old.items():
            signal.signal(sig, h)
        from ..engine import request_stop

        request_stop(None)  # (a stop asked of this process's runs by _let_runs_save)
        writer.flush()
    report.wall_seconds = time.perf_counter() - t0
    return _finish(report, writer, tasks)


def _run_on_cluster(todo, scheduler, workers, writer, report, progress, log) -> None:
    """Run the tasks ``todo`` on a dask cluster (``_connect``), the longest first; each
    finished run's row goes to ``writer`` as it comes (a failed worker: an error row)."""
    from distributed import as_completed

    client = cluster = bar = None
    by_key, futures = {}, []
    try:
        client, cluster = _connect(scheduler, workers, log)
        if scheduler is not None:
            report.workers = len(client.scheduler_info().get("workers", {}))
        client.run(warm_kernels, todo[0].options.method)
        for n in sorted({t.params.segments for t in todo}, reverse=True):  # the longest runs first
            group = [t for t in todo if t.params.segments == n]
            fs = client.map(
                run_task, group, key=[f"ballchain-{t.run_id}" for t in group], pure=False, priority=n, retries=0
            )
            for f, t in zip(fs, group):
                by_key[f.key] = t
            futures.extend(fs)
        bar = _Bar(len(todo), progress, log)
        for fut in as_completed(futures):
            task = by_key[fut.key]
            _record(fut, task, writer, report)
            bar.advance(report.failed)
            fut.release()
    except _Stop as exc:
        if client is not None:
            _let_runs_save(client, futures, by_key, writer, report, str(exc), log)
        raise
    finally:
        if bar is not None:
            bar.close()
        for thing in (client, cluster):
            if thing is not None:
                try:
                    thing.close(timeout=10)
                except Exception:  # noqa: BLE001
                    pass


def _record(fut, task, writer, report) -> None:
    """The row of a finished task into the table (a failed worker: an error row); an
    interrupted run's row is not written (the same command runs it again)."""
    try:
        row = fut.result()
    except Exception as exc:  # noqa: BLE001 - e.g. KilledWorker: the worker died in this run
        row = error_row(task, f"worker failed: {type(exc).__name__}: {exc}".splitlines()[0])
    if row["status"] == "interrupted":
        return
    writer.add(row)
    report.ran += 1
    report.failed += row["status"] == "error"


def _let_runs_save(client, futures, by_key, writer, report, reason: str, log) -> None:
    """An interrupted sweep: ask the runs under way to stop at their next return from
    compiled code, as a first Ctrl-C asks one run (``engine.request_stop``), and the tasks
    not started to return at once.  Without checkpoints only in this process, whose thread
    runs the tasks of a one-worker sweep (signals do not reach it: it would run on, and the
    process with it, after the sweep said it was interrupted; the worker processes of a
    larger cluster end with it), and the tasks are cancelled.  With checkpoints in every
    worker too, so that each run saves its checkpoint: waits STOP_WAIT s at most (a second
    Ctrl-C: at once); runs that ended meanwhile get their rows."""
    from distributed import wait

    from ..engine import request_stop

    left = [f for f in futures if not f.done()]
    request_stop(reason)
    if not any(by_key[f.key].checkpoint_path is not None for f in left):
        try:
            client.cancel(left)
        except Exception:  # noqa: BLE001 - a cluster already gone: nothing runs on
            pass
        return
    print(
        f"\nsweep interrupted ({reason}): the runs under way save their checkpoints (Ctrl-C again: at once)...",
        file=log,
        flush=True,
    )
    try:
        client.run(request_stop, reason)
    except Exception:  # noqa: BLE001 - a worker gone: its runs keep their last periodic checkpoint
        pass
    try:
        wait(left, timeout=STOP_WAIT)
    except Exception:  # noqa: BLE001 - the wait spent: the runs not stopped keep their last periodic checkpoint
        pass
    for f in left:
        if f.done() and f.status == "finished":
            _record(f, by_key[f.key], writer, report)


def _finish(report: SweepReport, writer: TableWriter, tasks) -> SweepReport:
    statuses: dict = {}
    for t in tasks:
        row = writer.rows.get(t.run_id)
        if row is not None:
            statuses[row["status"]] = statuses.get(row["status"], 0) + 1
    report.statuses = statuses
    return report


class _Bar:
    """Runs done / total with elapsed time and ETA: a rich bar on a terminal, else a line
    every 30 s (or 10% of the runs)."""

    def __init__(self, total: int, enabled: bool, log):
        self.total, self.done, self.enabled, self.log = total, 0, enabled, log
        self.t0 = self.last = time.monotonic()
        self.rich = None
        if enabled and getattr(log, "isatty", lambda: False)():
            from rich.console import Console
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self.rich = Progress(
                TextColumn("sweep"),
                BarColumn(),
                MofNCompleteColumn(),
                TimeElapsedColumn(),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                TextColumn("{task.fields[info]}"),
                console=Console(file=log),
                transient=False,
            )
            self.task = self.rich.add_task("sweep", total=total, info="")
            self.rich.start()

    def advance(self, failed: int) -> None:
        self.done += 1
        if not self.enabled:
            return
        if self.rich is not None:
            self.rich.update(self.task, advance=1, info=f"failed {failed}" if failed else "")
            return
        now = time.monotonic()
        tenth = int(10 * self.done / self.total) > int(10 * (self.done - 1) / self.total)
        if now - self.last >= 30.0 or self.done == self.total or tenth:
            el = now - self.t0
            eta = el / self.done * (self.total - self.done)
            print(
                f"sweep: {self.done}/{self.total} runs, {failed} failed, elapsed {_hms(el)}, ETA {_hms(eta)}",
                file=self.log,
                flush=True,
            )
            self.last = now

    def close(self) -> None:
        if self.rich is not None:
            self.rich.stop()


def _hms(s: float) -> str:
    s = int(round(s)) if math.isfinite(s) else 0
    return f"{s // 3600}h{s % 3600 // 60:02d}m" if s >= 3600 else f"{s // 60}m{s % 60:02d}s"
