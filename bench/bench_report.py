"""Benchmark: rendering the HTML report of an 8-hour, 4-worker shift from stored results.

report_8h_4workers: wall time of ``render_report`` on a report folder whose results/ holds an
8-hour shift at 12 fps (345,600 frames per worker; seeded synthetic results from
tests/report/report_synthetic.py): reading the stored JSON and Parquet files, building every page
context (timelines downsampled for display, floor maps from every frame), rendering and writing
the pages. Goal: under 10 s, every page under 3 MB. Also reported: the size of each page.
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests" / "report"))

from bench.common import best_time, emit  # noqa: E402
from ergopose.report.render import render_report  # noqa: E402
from ergopose.report.results import save_results  # noqa: E402
from report_synthetic import synthetic_session  # noqa: E402

HOURS = 8
WORKERS = 4
FPS = 12.0


def main() -> None:
    t0 = time.perf_counter()
    session, workers = synthetic_session(n_workers=WORKERS, duration_s=HOURS * 3600.0, fps=FPS, seed=8, gaps=False)
    frames = len(workers[0][2])
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "shift"
        save_results(folder, session, workers)
        prepare = time.perf_counter() - t0
        results_mb = sum(p.stat().st_size for p in (folder / "results").rglob("*") if p.is_file()) / 1e6
        sizes = {}

        def run() -> None:
            files = render_report(folder)
            sizes.update(files.sizes)

        seconds = best_time(run, repeat=3, warmup=1)
    emit(
        "report_8h_4workers",
        seconds,
        "s",
        goal_s=10.0,
        workers=WORKERS,
        hours=HOURS,
        fps=FPS,
        frames_session=int(HOURS * 3600 * FPS),
        frames_per_worker=frames,
        results_mb=round(results_mb, 2),
        max_page_mb=round(max(sizes.values()) / 1e6, 3),
        prepare_s=round(prepare, 2),
    )
    for name, size in sorted(sizes.items()):
        emit("report_8h_4workers_page_size", size / 1e6, "MB", page=name, goal_mb=3.0)


if __name__ == "__main__":
    main()
