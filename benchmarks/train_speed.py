"""Wall time of ``nlos generate`` + ``nlos train`` for a preset, against the 15-minute target for
the ``small`` demo on 2 CPU cores (DESIGN section 8: "small (the demo, minutes on 2 CPU cores)").

Each stage runs as its own ``nlos`` process, exactly as a user would type it, so imports and data
loading are counted. Given an existing, finished dataset (``DATA`` with a manifest.json), only
training is timed; otherwise the preset's dataset is generated first (into ``DATA``, or a temporary
directory) and both stages are timed.

    python benchmarks/train_speed.py [DATA] [--preset small] [--train-preset PRESET] [--keep RUN_DIR]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 15 * 60
"""The target for generating and training the ``small`` preset on 2 CPU cores."""


def run_stage(args: list[str]) -> float:
    """Run ``nlos ARGS`` quietly; return its wall time in seconds (exit on failure)."""
    cmd = [sys.executable, "-m", "nlos_spotlight.cli", *args]
    t = time.perf_counter()
    proc = subprocess.run(cmd, env={**os.environ, "NLOS_QUIET": "1"}, capture_output=True, text=True)
    elapsed = time.perf_counter() - t
    if proc.returncode != 0:
        sys.exit(f"failed ({proc.returncode}): {' '.join(args)}\n{proc.stderr.strip()}")
    return elapsed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("data", nargs="?", help="dataset directory: reused if finished, else generated here")
    ap.add_argument("--preset", default="small", help="dataset preset to generate (default small)")
    ap.add_argument("--train-preset", help="training preset or YAML (default: the same name as --preset)")
    ap.add_argument("--keep", help="run directory to keep (default: a temporary one)")
    args = ap.parse_args()
    train_cfg = args.train_preset or args.preset
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(args.data) if args.data else Path(tmp) / "data"
        run = Path(args.keep) if args.keep else Path(tmp) / "run"
        t_gen = None
        if (data / "manifest.json").is_file():
            print(f"dataset {data}: exists, not timed")
        else:
            t_gen = run_stage(["generate", args.preset, "--out", str(data), "--quiet"])
            print(f"nlos generate {args.preset}: {t_gen:.1f} s")
        t_train = run_stage(["train", train_cfg, "--data", str(data), "--out", str(run), "--quiet"])
        print(f"nlos train {train_cfg}: {t_train:.1f} s")
    total = t_train + (t_gen or 0.0)
    what = "generate + train" if t_gen is not None else "train"
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"{what}: {total:.1f} s = {total / 60:.1f} min on {cores} CPU cores; "
          f"{total / TARGET_S:.2f} x the 15-minute target")


if __name__ == "__main__":
    main()
