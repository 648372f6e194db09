"""How long to train a room model: a finished fit's people, retrained for several epoch counts.

The fit's own recipe (``fit.train.fit_train_config``: capture, spot policy, network) on its saved
people, each epoch count a resumable run under ``--runs``; prints and writes a CSV of held-out
posture accuracy, grouped accuracy, error and training time.

    python experiments/fit-budget/fit_budget.py out/fits/copyroom --epochs 10,30,60 [--people 1000,3000]
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path


def main(argv: list[str] | None = None) -> None:
    import torch

    from nlos_spotlight.train.recipe import run_seen
    from nlos_spotlight.fit.config import FitConfig
    from nlos_spotlight.fit.train import fit_train_config, room_split

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("model", help="a finished room model directory (nlos fit --out)")
    ap.add_argument("--epochs", default="10,30,60")
    ap.add_argument("--people", help="training people (default: the fit's)")
    ap.add_argument("--runs", help="run directories (default: MODEL/budget)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", help="CSV (default: MODEL/budget/fit-budget.csv)")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    model = Path(args.model)
    settings = json.loads((model / "fit.json").read_text())["settings"]
    cfg = FitConfig.from_record(settings)
    runs = Path(args.runs) if args.runs else model / "budget"
    split = room_split(model, cfg, ["normals"])
    rows = []
    for n in [int(v) for v in (args.people or str(cfg.people)).split(",")]:
        for e in [float(v) for v in args.epochs.split(",")]:
            r = run_seen(fit_train_config(cfg, model), [split], n, runs / f"n{n}-e{e:g}", e, min_steps=cfg.min_steps)
            rows.append({"people": n, "epochs": e, "steps": r.steps, "posture_accuracy": round(r.posture_accuracy, 1),
                         "posture3_accuracy": round(r.posture3_accuracy, 1), "error_cm": round(r.error_cm, 1),
                         "seconds": round(r.seconds, 1)})
            print(rows[-1], flush=True)
    out = Path(args.out) if args.out else runs / "fit-budget.csv"
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
