"""The assessment on Dask against one local process: assess_cluster_speedup.

One simulated session (2 workers, ERGOPOSE_BENCH_CLUSTER_MINUTES long, default 1 minute, seed 0)
is assessed three times, each into a fresh output folder: with one local process
(``--processes 1``), on a LocalCluster of one worker process (``--cluster local:1``) and of two
(``--cluster local:2``). One JSON line per run; value: the single-process wall time divided by
the run's wall time (the speedup; 1.0 for the single-process run itself). Context: wall and
video-work (pose stage) seconds and the pose stage's speedup, whether the run's CSV files are
the bytes of the single-process run's, the cores and the load average (other work on the
machine slows every figure). The LocalCluster's start (worker processes, network loading) is
in the wall time; the simulation is not timed.
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

from ergopose.pipeline.assess import AssessOptions, assess  # noqa: E402
from ergopose.pipeline.cluster import assess_sessions  # noqa: E402
from ergopose.sim.writer import SimulationConfig, simulate_session  # noqa: E402

MINUTES = float(os.environ.get("ERGOPOSE_BENCH_CLUSTER_MINUTES", "1"))
RUNS = (("processes 1", None), ("cluster local:1", "local:1"), ("cluster local:2", "local:2"))


def _csv_bytes(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted((out / "csv").glob("*.csv"))}


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        session = Path(tmp) / "day1"
        simulate_session(session, SimulationConfig(workers=2, minutes=MINUTES, seed=0))
        timed = []
        for k, (name, address) in enumerate(RUNS):
            options = AssessOptions(out_dir=Path(tmp) / f"report{k}", processes=1)
            t0 = time.perf_counter()
            if address is None:
                result = assess(session, options)
            else:
                (outcome,) = assess_sessions([session], address, options)
                if outcome.error is not None:
                    raise outcome.error
                result = outcome.result
            timed.append(
                (
                    name,
                    time.perf_counter() - t0,
                    result.stage_seconds.get("pose", float("nan")),
                    _csv_bytes(options.out_dir),
                    result.frames,
                    [round(x, 2) for x in os.getloadavg()],
                )
            )
    base_wall, base_pose, base_csv = timed[0][1], timed[0][2], timed[0][3]
    for name, wall, pose, csv, frames, load in timed:
        emit(
            "assess_cluster_speedup",
            base_wall / wall,
            "x",
            run=name,
            wall_s=round(wall, 1),
            pose_s=round(pose, 1),
            pose_speedup=round(base_pose / pose, 2),
            identical_csv=csv == base_csv,
            session_minutes=MINUTES,
            workers=2,
            frames=frames,
            load_average=load,
        )  # at the end of this run


if __name__ == "__main__":
    main()
