"""The whole assessment against the clock: assess_realtime_factor.

A 5-minute, 2-worker simulated session (default size, 12 fps, seed 0) is made in a temporary
folder, then assessed with one process per core; the factor is the assessment's wall time divided
by the session's length (below 1.0: faster than real time). The simulation itself is not timed.
Context fields: seconds per stage, processes, the load average, and the peak memory of the run.
"""

from __future__ import annotations

import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import emit  # noqa: E402

from ergopose.pipeline.assess import AssessOptions, assess  # noqa: E402
from ergopose.sim.writer import SimulationConfig, simulate_session  # noqa: E402

MINUTES = float(os.environ.get("ERGOPOSE_BENCH_ASSESS_MINUTES", "5"))


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        session = Path(tmp) / "day1"
        simulate_session(session, SimulationConfig(workers=2, minutes=MINUTES, seed=0))
        t0 = time.perf_counter()
        result = assess(session, AssessOptions(out_dir=Path(tmp) / "report"))
        wall = time.perf_counter() - t0
    peak_mb = (
        max(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)
        / 1024.0
    )
    emit(
        "assess_realtime_factor",
        wall / (MINUTES * 60.0),
        "x",
        goal=1.0,
        session_minutes=MINUTES,
        workers=2,
        frames=result.frames,
        wall_s=round(wall, 1),
        processes=os.cpu_count(),
        stage_s={k: round(v, 1) for k, v in result.stage_seconds.items()},
        peak_rss_mb=round(peak_mb, 1),
        load_average=[round(x, 2) for x in os.getloadavg()],
    )


if __name__ == "__main__":
    main()
