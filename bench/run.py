"""Run every benchmark in bench/ and pass on its JSON lines.

Each bench/bench_*.py is run in its own process (so one cannot slow another through caches or
threads) and prints one JSON object per line: {"bench": NAME, "value": NUMBER, "unit": UNIT, ...}.
Usage: python bench/run.py [SUBSTRING ...] runs only the files whose names contain a substring.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str]) -> int:
    files = sorted(HERE.glob("bench_*.py"))
    if argv:
        files = [f for f in files if any(s in f.name for s in argv)]
    failed = []
    # One OpenBLAS thread, as the product runs (ergopose/__init__.py sets it unless the user did), also
    # in the benches that import numpy before ergopose (bench_recon's body fit and aniposelib alike).
    env = dict(os.environ)
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    for f in files:
        proc = subprocess.run([sys.executable, str(f)], capture_output=True, text=True, cwd=HERE.parent, env=env)
        for line in proc.stdout.splitlines():
            line = line.strip()
            if not line:
                continue
            try:
                record = json.loads(line)
            except json.JSONDecodeError:
                print(f"{f.name}: not JSON: {line}", file=sys.stderr)
                continue
            print(json.dumps(record), flush=True)
        if proc.returncode != 0:
            failed.append(f.name)
            print(f"{f.name} failed:\n{proc.stderr[-2000:]}", file=sys.stderr)
    if failed:
        print(f"benchmarks failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
