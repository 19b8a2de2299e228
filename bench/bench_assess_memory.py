"""Memory of the stages after the 2D work over long shifts: assess_stages_peak_rss_mb.

An assessment stores the people found in each chunk of video (pipeline/chunks/), then tracks,
smooths, scores and reports the whole shift from them (ergopose.pipeline.track, score, aggregate, publish). This bench
writes such chunk files for simulated shifts of two workers (the simulator's motion, 1 cm
noise, 12 fps; no video) of SHORT and LONG minutes, runs the tracking, scoring and report
stages on each in a fresh process, and prints each process's peak resident memory. The 2D stage
works chunk by chunk in worker processes whatever the shift length, so it is not part of this.

Bounded memory means the LONG shift needs about what the SHORT one needs: the
``assess_memory_growth`` line is the ratio LONG / SHORT (1.0 = no growth), and
``assess_memory_per_shift_minute`` the peak's growth per minute of shift between them (MB/min;
0 = bounded). Scoring holds one block of up to 10 minutes and its context (92 s on both sides)
per worker (ergopose.pipeline.scoring), so only a SHORT of 12 minutes or more compares full
blocks (measured 2026-11-26: 24 min 405 MB, 60 min 423 MB, 120 min 428 MB; docs/assess.md).
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from common import emit  # noqa: E402

SHORT = float(os.environ.get("ERGOPOSE_BENCH_MEMORY_SHORT_MINUTES", "10"))
LONG = float(os.environ.get("ERGOPOSE_BENCH_MEMORY_LONG_MINUTES", "60"))
FPS = 12.0
CHUNK_S = 10.0


def make_chunks(out: Path, minutes: float) -> None:
    """The chunk files an assessment of a simulated two-worker shift would store."""
    import numpy as np

    from ergopose.pipeline.detect import ChunkResult, chunk_ranges
    from ergopose.pipeline.store import ResultStore
    from ergopose.recon.records import People3D
    from ergopose.sim.motion import simulate_motion
    from ergopose.sim.scene import default_scene

    rng = np.random.default_rng(0)
    store = ResultStore(out)
    store.open({"bench": "simulated motion", "minutes": minutes, "fps": FPS})  # the chunks' inputs
    n = int(round(minutes * 60 * FPS))
    m = simulate_motion(default_scene(), 2, n / FPS, FPS, seed=0)
    for start, stop in chunk_ranges(n, int(CHUNK_S * FPS)):
        X = m.joints_world[start:stop] + rng.normal(0, 0.01, m.joints_world[start:stop].shape)  # (F, 2, 33, 3)
        f = np.repeat(np.arange(start, stop), 2)
        people = People3D.from_points(f, f / FPS, X.reshape(-1, 33, 3))
        store.save_chunk(ChunkResult(start, stop, people, np.full((stop - start, 2), 2, np.int16)))


def run_stages(session_dir: Path, out: Path, minutes: float) -> None:
    """Tracking, scoring, CSV files and the report from the stored chunks; prints the peak RSS (MB)."""
    import resource

    from ergopose.pipeline import assess, inputs, track
    from ergopose.pipeline.detect import chunk_ranges
    from ergopose.pipeline.store import ResultStore
    from ergopose.recon.settings import ReconSettings
    from ergopose.session import load_session

    session = load_session(session_dir)
    store = ResultStore(out)
    ranges = chunk_ranges(int(round(minutes * 60 * FPS)), int(CHUNK_S * FPS))
    recon = ReconSettings()
    tracks = track.track_session(session, store, ranges, recon, None)
    assess.score_and_publish(session, tracks, out, inputs.scoring_settings(session), (), None)
    print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0)


def main() -> None:
    if len(sys.argv) > 1:
        cmd, *args = sys.argv[1:]
        if cmd == "chunks":
            make_chunks(Path(args[0]), float(args[1]))
        elif cmd == "stages":
            run_stages(Path(args[0]), Path(args[1]), float(args[2]))
        return
    from ergopose.sim.writer import SimulationConfig, simulate_session

    peaks = {}
    with tempfile.TemporaryDirectory() as tmp:
        session = Path(tmp) / "day1"  # calibration and settings; its 1-second videos are not used
        simulate_session(session, SimulationConfig(workers=2, minutes=1 / 60, seed=0))
        for minutes in (SHORT, LONG):
            out = Path(tmp) / f"report_{minutes:g}"
            me = [sys.executable, __file__]
            subprocess.run([*me, "chunks", str(out), str(minutes)], check=True)
            done = subprocess.run(
                [*me, "stages", str(session), str(out), str(minutes)], check=True, capture_output=True, text=True
            )
            peaks[minutes] = float(done.stdout.strip().splitlines()[-1])
            emit("assess_stages_peak_rss_mb", peaks[minutes], "MB", shift_minutes=minutes, workers=2, fps=FPS)
    emit("assess_memory_growth", peaks[LONG] / peaks[SHORT], "x", goal=1.0, short_minutes=SHORT, long_minutes=LONG)
    emit(
        "assess_memory_per_shift_minute",
        (peaks[LONG] - peaks[SHORT]) / (LONG - SHORT),
        "MB/min",
        short_minutes=SHORT,
        long_minutes=LONG,
        workers=2,
        fps=FPS,
    )


if __name__ == "__main__":
    main()
