"""Peak memory of a Dask worker over a short and a longer session: assess_cluster_worker_peak_rss_mb.

Each session (a simulated shift of two workers, seed 0) of SHORT and of LONG minutes is assessed
with ``--cluster`` on a fresh LocalCluster of one one-thread worker process (the one ``local:1``
starts: ergopose.pipeline.cluster.local_cluster), so that the one worker runs every task: the chunk tasks (video work), the session task
(tracking, CSV files, report) and the per-worker scoring tasks. The worker's peak resident memory
(``ru_maxrss`` of its process) is read twice: when the last chunk is stored (the video work,
with the pose networks loaded) and at the end (all of it); its resident memory is also read
after each chunk is stored (``rss_after_first_chunk_mb``, ``rss_after_last_chunk_mb``). The
simulation is not measured.

Bounded memory means the LONG session needs about what the SHORT one needs: the
``assess_cluster_worker_memory_growth`` line is the ratio LONG / SHORT of the peaks (1.0 = no
growth), and ``assess_cluster_worker_memory_per_session_minute`` the peak's growth per minute
of session (MB/min); one line each for the video work and the whole run. Environment:
ERGOPOSE_BENCH_CLUSTER_MEMORY_SHORT_MINUTES (default 0.5), ..._LONG_MINUTES (default 2).
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import emit  # noqa: E402

SHORT = float(os.environ.get("ERGOPOSE_BENCH_CLUSTER_MEMORY_SHORT_MINUTES", "0.5"))
LONG = float(os.environ.get("ERGOPOSE_BENCH_CLUSTER_MEMORY_LONG_MINUTES", "2"))


def _peak_mb() -> float:
    """Run on the worker: its process's peak resident memory, MB."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _rss_mb() -> float:
    """Run on the worker: its process's resident memory now, MB."""
    import psutil

    return psutil.Process().memory_info().rss / 2**20


def measure(session: Path, out: Path) -> dict[str, float]:
    """One run on a fresh one-worker LocalCluster: the worker's peaks (MB) after the video work and
    at the end, its resident memory at the end, and the run's wall and chunk count."""
    from distributed import Client

    from ergopose.pipeline.assess import AssessOptions
    from ergopose.pipeline.cluster import assess_sessions, local_cluster

    figures: dict[str, float] = {}
    series: list[float] = []
    with local_cluster(1) as lc, Client(lc) as probe:

        def watch(event) -> None:
            if event.stage == "pose" and event.done > 0:  # a chunk stored: the worker's memory now
                series.append(next(iter(probe.run(_rss_mb).values())))
            if event.stage == "pose" and event.total and event.done >= event.total and "pose" not in figures:
                figures["pose"] = next(iter(probe.run(_peak_mb).values()))

        t0 = time.perf_counter()
        (outcome,) = assess_sessions(
            [session], lc.scheduler_address, AssessOptions(out_dir=out, processes=1), progress=watch
        )
        if outcome.error is not None:
            raise outcome.error
        figures["wall_s"] = time.perf_counter() - t0
        figures["all"] = next(iter(probe.run(_peak_mb).values()))
        figures["rss_end"] = next(iter(probe.run(_rss_mb).values()))
        figures["chunks"] = outcome.result.chunks_total
        figures["frames"] = outcome.result.frames
    figures["rss_first_chunk"] = series[0] if series else float("nan")
    figures["rss_last_chunk"] = series[-1] if series else float("nan")
    figures["series"] = [round(x, 1) for x in series]  # type: ignore[assignment]
    return figures


def main() -> None:
    from ergopose.sim.writer import SimulationConfig, simulate_session

    runs = {}
    with tempfile.TemporaryDirectory() as tmp:
        for minutes in (SHORT, LONG):
            session = Path(tmp) / f"day_{minutes:g}"
            simulate_session(session, SimulationConfig(workers=2, minutes=minutes, seed=0))
            f = runs[minutes] = measure(session, Path(tmp) / f"report_{minutes:g}")
            for phase, what in (("pose", "video work (chunk tasks)"), ("all", "whole run")):
                emit(
                    "assess_cluster_worker_peak_rss_mb",
                    f[phase],
                    "MB",
                    phase=what,
                    session_minutes=minutes,
                    frames=int(f["frames"]),
                    chunks=int(f["chunks"]),
                    rss_at_end_mb=round(f["rss_end"], 1),
                    rss_after_first_chunk_mb=round(f["rss_first_chunk"], 1),
                    rss_after_last_chunk_mb=round(f["rss_last_chunk"], 1),
                    wall_s=round(f["wall_s"], 1),
                    workers=2,
                    cluster="local:1",
                    load_average=[round(x, 2) for x in os.getloadavg()],
                )
    for phase, what in (("pose", "video work (chunk tasks)"), ("all", "whole run")):
        emit(
            "assess_cluster_worker_memory_growth",
            runs[LONG][phase] / runs[SHORT][phase],
            "x",
            goal=1.0,
            phase=what,
            short_minutes=SHORT,
            long_minutes=LONG,
        )
        emit(
            "assess_cluster_worker_memory_per_session_minute",
            (runs[LONG][phase] - runs[SHORT][phase]) / (LONG - SHORT),
            "MB/min",
            phase=what,
            short_minutes=SHORT,
            long_minutes=LONG,
        )


if __name__ == "__main__":
    main()
