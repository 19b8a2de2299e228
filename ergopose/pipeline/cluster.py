"""``ergopose assess --cluster ADDRESS``: the work of one or many sessions on a Dask cluster.

The same pieces as a local run (:mod:`ergopose.pipeline.assess`), placed on Dask workers:

* the client (this process) checks each session and its output folder, fetches the pose models,
  holds the output folder's lock and reads which chunks are already stored (the driver's
  ``prepare`` and ``open_store``);
* every chunk still to compute is one task: a worker reads the videos from the path the session
  names (a folder every worker sees at the same path), runs the 2D stage and triangulation, and
  stores the chunk in the session's output folder before the task ends, exactly as a local
  worker process does; only (start, stop) comes back to the client;
* one more task per session, run once all its chunks are stored, does the tracking (with the
  body fit), the per-worker scoring, the CSV files and the report (the driver's ``finish``: track
  and smooth, score, aggregate, publish), streaming the stored chunks as a local run does; its
  warnings come back to the client.

A killed client or a lost worker costs only the chunks being computed at that moment: stored
chunks are kept (and checked) and the next run, or Dask rescheduling the lost worker's tasks,
computes the rest. The results are the same bytes as a local run's.

Each Dask worker loads the pose networks once, when it joins (:class:`PoseModels`, a Dask
worker plugin), and runs them with one inference thread; networks are never sent between
processes. A worker with several threads runs one chunk at a time (:data:`_INFERENCE_LOCK`).

Sessions fail alone: an error in one session (a damaged video, a bad settings file) is that
session's outcome, the others go on.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import dask
from distributed import Client, Future, LocalCluster, WorkerPlugin, as_completed, worker_client

from ergopose import __version__, remote
from ergopose.atomic import clean_up
from ergopose.errors import ConfigError
from ergopose.pipeline import assess as local
from ergopose.pipeline import detect, guard
from ergopose.pipeline.store import ResultStore
from ergopose.progress import ProgressCallback, ProgressEvent, report

#: ``local:N``: a Dask LocalCluster of N worker processes on this machine.
LOCAL_PREFIX = "local:"

#: Dask settings of the LocalClusters this module starts. The workers' statistical profiler is off:
#: it keeps up to 1000 one-second profiles (``distributed.admin.low-level-log-length``), which made
#: a worker's memory grow by about 6 MB per 10-s chunk for the first quarter of an hour
#: (bench/bench_assess_cluster_memory.py; docs/cluster.md, "Memory").
LOCAL_CLUSTER_CONFIG = {"distributed.worker.profile.enabled": False}

#: One chunk at a time per worker process, whatever its thread count: a network is not used by
#: two threads at once.
_INFERENCE_LOCK = threading.Lock()


@dataclass(frozen=True)
class SessionOutcome:
    """One session of a cluster run: its result, or the error that stopped it (and only it)."""

    session: Path
    out_dir: Path | None
    result: local.AssessResult | None = None
    error: BaseException | None = None


def parse_address(address: str) -> tuple[str, int | str]:
    """("local", N) for ``local:N``, else ("remote", the scheduler address, e.g. tcp://host:8786)."""
    text = str(address).strip()
    if text.startswith(LOCAL_PREFIX):
        n = text[len(LOCAL_PREFIX) :]
        if not n.isdigit() or int(n) < 1:
            raise ConfigError(f"expected local:N with N at least 1 worker process, got {address!r}", field="--cluster")
        return "local", int(n)
    if "://" not in text and ":" not in text:
        raise ConfigError(
            f"expected a scheduler address such as tcp://host:8786, or local:N, got {address!r}", field="--cluster"
        )
    return "remote", text


class PoseModels(WorkerPlugin):
    """Dask worker plugin: the pose networks loaded once per worker process, when it starts (and
    when a restarted worker joins again). The networks stay in the process
    (:func:`ergopose.pipeline.detect.networks`); only the model folder is sent."""

    name = "ergopose-pose-models"

    def __init__(self, model_dir: str | None, model: str | None = None) -> None:
        self.model_dir = model_dir
        self.model = model

    def setup(self, worker: Any = None) -> None:
        detect.networks(self.model_dir, 1, self.model)

    def teardown(self, worker: Any = None) -> None:
        pass


def _worker_version() -> str:
    return __version__  # run on each worker: the version installed there


def local_cluster(n_workers: int) -> LocalCluster:
    """The LocalCluster of ``local:N``: N one-thread worker processes, the dashboard on a free port,
    the workers' profiler off (:data:`LOCAL_CLUSTER_CONFIG`; a restarted worker keeps it off)."""
    with dask.config.set(LOCAL_CLUSTER_CONFIG):
        return LocalCluster(  # type: ignore[no-untyped-call]  # distributed's LocalCluster has no annotations
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        )


@contextlib.contextmanager
def connect(
    address: str, model_dir: str | None, progress: ProgressCallback | None = None, model: str | None = None
) -> Iterator[Any]:
    """A Dask client for ``address`` (a LocalCluster of N one-thread worker processes for local:N),
    with the pose networks loaded on every worker; the dashboard address is reported (stage
    "cluster", unit "note"). Closed (and a LocalCluster shut down) on leaving."""
    kind, where = parse_address(address)
    with contextlib.ExitStack() as stack:
        if kind == "local":
            cluster = stack.enter_context(local_cluster(int(where)))
            client = stack.enter_context(Client(cluster))  # type: ignore[no-untyped-call]  # distributed's Client has no annotations
        else:
            try:
                client = stack.enter_context(Client(str(where), timeout="30s"))  # type: ignore[no-untyped-call]  # distributed's Client has no annotations
            except OSError as exc:
                raise ConfigError(f"cannot reach the Dask scheduler at {where} ({exc})", field="--cluster") from None
        versions = set(client.run(_worker_version).values())
        if versions - {__version__}:
            raise ConfigError(
                f"the Dask workers run ergopose {', '.join(sorted(versions))}, this is {__version__}: "
                "install the same version everywhere",
                field="--cluster",
            )
        client.register_plugin(PoseModels(model_dir, model), name=PoseModels.name)
        info = client.scheduler_info()
        workers = info.get("workers", {})
        threads = sorted({w.get("nthreads", 1) for w in workers.values()})
        dashboard = client.dashboard_link if "dashboard" in info.get("services", {}) else "none (needs bokeh)"
        report(
            progress,
            "cluster",
            0,
            None,
            unit="note",
            message=f"scheduler {client.scheduler.address}, {len(workers)} workers, dashboard {dashboard}",
        )
        if threads and threads[-1] > 1:
            report(
                progress,
                "cluster",
                0,
                None,
                unit="note",
                message="workers with more than one thread run one chunk at a time; start them with --nthreads 1",
            )
        yield client


def session_out_dirs(session_dirs: Sequence[str | Path], out_dir: str | Path | None) -> list[Path | None]:
    """Each session's output folder: for one session the given one (None: the default); for
    several, <out>/<session folder name> (default reports/<name>). Two sessions of the same
    folder name are a ConfigError."""
    dirs = [Path(d) for d in session_dirs]
    if len(dirs) == 1:
        return [Path(out_dir) if out_dir is not None else None]
    names = [d.resolve().name for d in dirs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError(
            f"sessions of the same folder name ({', '.join(twice)}) would share an output folder; "
            "assess them in separate runs",
            field="--sessions",
        )
    base = Path(out_dir) if out_dir is not None else Path("reports")
    return [base / n for n in names]


def _labelled(progress: ProgressCallback | None, label: str | None) -> ProgressCallback | None:
    """Progress of one session among several: its stages (and warnings) named with the session."""
    if progress is None or label is None:
        return progress

    def relay(event: ProgressEvent) -> None:
        if event.unit == "note":
            progress(dataclasses.replace(event, message=f"{label}: {event.message}"))
        else:
            progress(dataclasses.replace(event, stage=f"{label} {event.stage}"))

    return relay


#: A video given as a URL: (URL, the path of its copy, its size in bytes when the client copied it).
Copy = tuple[str, str, int]


def _copies(run: local.PreparedRun) -> tuple[Copy, ...]:
    """The session's videos given as URLs, with the place of their copy (the client's: each worker
    copies the video to the same path on its machine)."""
    return tuple(
        (c.video_url, str(c.video_path), c.video_path.stat().st_size) for c in run.session.cameras if c.video_url
    )


def _fetch(copies: Sequence[Copy]) -> None:
    """On a worker: each video given as a URL copied to its place, unless there already."""
    for url, path, size in copies:
        remote.fetch(url, path, size=size)


def _forget(paths: Sequence[str]) -> int:
    return remote.forget(paths)


def _cluster_chunk(
    job: detect.DetectJob, store_root: str, start: int, stop: int, copies: Sequence[Copy] = ()
) -> tuple[int, int]:
    """Dask task: one chunk computed and stored (as a local worker process does)."""
    _fetch(copies)
    with _INFERENCE_LOCK:
        return local.chunk_task(job, store_root, start, stop)


def _cluster_finish(
    run: local.PreparedRun, ranges: Sequence[tuple[int, int]], reused: int, *chunks: Any, copies: Sequence[Copy] = ()
) -> tuple[local.AssessResult, list[ProgressEvent]]:
    """Dask task, once every chunk of the session is stored: tracking, scoring, CSV files and the
    report; returns the result and the warnings met."""
    _fetch(copies)  # the recording's fingerprint reads the videos' first and last bytes
    events: list[ProgressEvent] = []

    def keep(event: ProgressEvent) -> None:
        events.append(event)

    with guard.output_faults(run.out_dir):
        clean_up(run.out_dir)  # what an earlier attempt of this task left, on a worker lost meanwhile
        result = local.finish(run, ranges, reused, keep, run_each=_as_tasks)
    return result, [e for e in events if e.unit == "note"]


def _as_tasks(calls: list[Callable[[], list[Any]]]) -> list[list[Any]]:
    """Run calls as tasks of the cluster this task runs on (each tracked worker's scoring), this
    task's thread leaving the worker's pool while it waits; their results in order."""
    with worker_client() as client:
        results: list[list[Any]] = client.gather(client.map(_call, calls, pure=False))
        return results


def _call(fn: Callable[[], Any]) -> Any:
    return fn()


@dataclass
class _Running:
    """Client-side bookkeeping of one session while its tasks run."""

    index: int
    run: local.PreparedRun
    progress: ProgressCallback | None
    total_frames: int
    done_frames: int
    t_submit: float
    chunks: list[Future[tuple[int, int]]] = dataclasses.field(default_factory=list)
    finish: Any = None
    pose_s: float | None = None
    copies: tuple[Copy, ...] = ()


def assess_sessions(
    session_dirs: Sequence[str | Path],
    address: str,
    options: local.AssessOptions = local.AssessOptions(),
    progress: ProgressCallback | None = None,
) -> list[SessionOutcome]:
    """Assess every session on the Dask cluster at ``address`` in one submission; one outcome per
    session, in the order given (see the module docstring). ``options.processes`` is not used
    (the cluster's workers do the work); ``options.out_dir`` is the output folder of a single
    session, the parent of one folder per session for several (:func:`session_out_dirs`)."""
    dirs = [Path(d).resolve() for d in session_dirs]  # as the workers see them (a shared folder)
    outs = session_out_dirs(dirs, options.out_dir)
    if options.model_dir is not None:
        options = dataclasses.replace(options, model_dir=str(Path(options.model_dir).resolve()))
    several = len(outs) > 1
    outcomes: list[SessionOutcome | None] = [None] * len(outs)
    with contextlib.ExitStack() as locks:
        running: list[_Running] = []
        with connect(address, options.model_dir, progress, options.model) as client:
            for i, (sdir, out) in enumerate(zip(dirs, outs)):
                label = sdir.name if several else None
                sp = _labelled(progress, label)
                try:
                    run = local.prepare(sdir, dataclasses.replace(options, out_dir=out), sp)
                    # absolute paths: the workers see the same shared folder, not this process's folder
                    run = dataclasses.replace(
                        run, out_dir=run.out_dir.resolve(), store=ResultStore(run.out_dir.resolve())
                    )
                    with guard.output_faults(run.out_dir):
                        locks.enter_context(run.store.lock())
                        ranges, done, todo = local.open_store(run, sp)
                except Exception as exc:  # this session fails alone
                    outcomes[i] = SessionOutcome(sdir, out, error=exc)
                    continue
                state = _Running(
                    i,
                    run,
                    sp,
                    total_frames=ranges[-1][1] if ranges else 0,
                    done_frames=sum(b - a for a, b in ranges) - sum(b - a for a, b in todo),
                    t_submit=time.perf_counter(),
                    copies=_copies(run),
                )
                msg = f"{len(done)} of {len(ranges)} chunks already done" if done else ""
                report(sp, "pose", state.done_frames, state.total_frames, unit="frame", message=msg)
                root = str(run.store.root.resolve())
                state.chunks = [
                    client.submit(_cluster_chunk, run.job, root, a, b, state.copies, pure=False) for a, b in todo
                ]
                state.finish = client.submit(
                    _cluster_finish, run, ranges, len(done), *state.chunks, copies=state.copies, pure=False
                )
                running.append(state)
            _follow(client, running, outcomes, dirs)
    return [o for o in outcomes if o is not None]


def _drop_copies(client: Client, st: _Running) -> None:
    """A session done: the copies of its videos given as URLs removed on every worker and here."""
    if not st.copies:
        return
    paths = [p for _, p, _ in st.copies]
    with contextlib.suppress(Exception):  # a worker gone meanwhile: its copies went with its machine or stay in tmp
        client.run(_forget, paths)
    remote.forget(paths)


def _follow(
    client: Client, running: list[_Running], outcomes: list[SessionOutcome | None], session_dirs: list[Path]
) -> None:
    """Progress per session as its tasks finish; each session's result or error into ``outcomes``."""
    owner: dict[Any, _Running] = {}
    for st in running:
        for f in (*st.chunks, st.finish):
            owner[f] = st
    pending = [f for st in running for f in (*st.chunks, st.finish)]
    try:
        for fut in as_completed(pending):  # type: ignore[no-untyped-call]  # distributed's as_completed has no annotations
            st = owner[fut]
            if fut is not st.finish:
                if fut.status == "finished":
                    start, stop = fut.result()
                    st.done_frames += stop - start
                    report(st.progress, "pose", st.done_frames, st.total_frames, unit="frame")
                    if all(c.status == "finished" for c in st.chunks):
                        st.pose_s = time.perf_counter() - st.t_submit
                continue
            run = st.run
            try:
                result, notes = fut.result()
            except Exception as exc:
                client.cancel([c for c in st.chunks if not c.done()])  # type: ignore[no-untyped-call]  # Client.cancel has no annotations
                _drop_copies(client, st)
                outcomes[st.index] = SessionOutcome(session_dirs[st.index], run.out_dir, error=exc)
                report(st.progress, "report", 0, 1, unit="step", message="failed")
                continue
            _drop_copies(client, st)
            for e in notes:
                report(st.progress, e.stage, e.done, e.total, unit=e.unit, message=e.message)
            timings = {**run.timings, "pose": st.pose_s if st.pose_s is not None else 0.0, **result.stage_seconds}
            result = dataclasses.replace(result, seconds=time.perf_counter() - run.t_start, stage_seconds=timings)
            outcomes[st.index] = SessionOutcome(session_dirs[st.index], run.out_dir, result=result)
            report(st.progress, "report", 1, 1, unit="step")
    except BaseException:
        client.cancel(pending)  # type: ignore[no-untyped-call]  # Client.cancel has no annotations
        raise
