"""The benchmark suite runs end to end (a tiny subset; speed is never asserted in tests)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def test_benchmark_smoke_mode_writes_results(tmp_path: Path) -> None:
    env = {**os.environ, "NEMC_CACHE": str(tmp_path / "cache")}
    out = tmp_path / "results"
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "run.py"), "--smoke", "--out", str(out)],
        capture_output=True, text=True, env=env, timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((out / "latest.json").read_text())
    assert set(result) >= {"environment", "rhs", "work_precision", "phases"}, sorted(result)
    assert (out / "latest.md").read_text().startswith("# nemc benchmark results")
