"""The paper's Tables 1-3 and Figures 5-6 on rooms no network trained in (issue 12).

Reads the per-person predictions that ``experiments/backprojection-across-rooms/backprojection_net.py``
(FloorNet: ours with the IEN's spot) and ``experiments/unseen-rooms/unseen_rooms.py`` (the image
networks and the baselines) write beside each run, every seed of every method, on the same 40 test
rooms of ``unseen-test.yaml`` under the same spots (each policy draws with the same new-room key) and the same sensor-noise seeds:

* Table 1: six-way posture accuracy per posture; Table 2: localization error per posture. Both on
  the static people (30 a room; the walks are Figure 5's), mean +- sample std over seeds.
* Table 3: every spot policy against every network (error / six-way accuracy), with each policy's
  spot SNR over the oracle's (``--snr``, ``experiments/unseen-rooms/unseen_rooms.py``'s
  ``spot-snr.csv``).
* Figure 5: ours on the test rooms' walks (20 frames at 5 Hz), raw and Savitzky-Golay smoothed
  (``evaluate.tracking``); Figure 6: error and accuracy per policy and network.

    python experiments/paper-tables-unseen-rooms/unseen_paper_tables.py --out docs/results/unseen-paper
"""

from __future__ import annotations

import argparse
import csv
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nlos_spotlight.evaluate.metrics import COLUMNS, class_scores
from nlos_spotlight.evaluate.tracking import smooth_trajectory


@dataclass(frozen=True)
class Row:
    """A method: a network's runs (one folder per seed) scored under one spot policy."""

    key: str
    label: str
    net: str
    """Key of :data:`NETS`."""
    policy: str


NETS = {
    "floor-net": ("FloorNet", "{bp}/t2-s{seed}/predictions-{policy}.npz"),
    "image": ("ResNet (image only)", "{runs}/default-image-200rooms-s{seed}/predictions-{policy}-40rooms.npz"),
    "geometry": ("ResNet + geometry", "{runs}/default-geometry-200rooms-s{seed}/predictions-{policy}-40rooms.npz"),
    "chandran": ("CNN (Chandran)", "{runs}/default-chandran-200rooms-s{seed}/predictions-{policy}-40rooms.npz"),
    "tancik": ("CNN (Tancik)", "{runs}/default-tancik-200rooms-s{seed}/predictions-{policy}-40rooms.npz"),
    "dlnlos": ("CNN (DL-NLOS)", "{runs}/default-dlnlos-200rooms-s{seed}/predictions-{policy}-40rooms.npz"),
}
"""Network -> (name in Table 3, where a seed's predictions under a policy are)."""

ROWS = (
    Row("ours", "Ours (IEN + FloorNet)", "floor-net", "ien"),
    Row("ien_resnet", "IEN + ResNet (the paper's pairing, image only)", "image", "ien"),
    Row("ien_cnn", "IEN + CNN (Chandran)", "chandran", "ien"),
    Row("al_resnet", "AL + ResNet", "image", "adaptive"),
    Row("random_resnet", "Random + ResNet", "image", "random"),
    Row("center_resnet", "Center + ResNet", "image", "center"),
    Row("oracle_resnet", "Oracle + ResNet", "image", "oracle"),
    Row("oracle_floornet", "Oracle + FloorNet", "floor-net", "oracle"),
    Row("chandran", "Chandran & Jayasuriya (AL + CNN)", "chandran", "adaptive"),
    Row("tancik", "Tancik et al. (flash + CNN)", "tancik", "flash"),
    Row("dlnlos", "DL-NLOS (ambient + CNN)", "dlnlos", "ambient"),
)
"""Tables 1-2, ours first (the paper's rows, FloorNet beside the oracle)."""

POLICIES = ("ien", "adaptive", "oracle", "center", "random")
GRID_NETS = ("floor-net", "geometry", "image", "chandran")


def load(path: Path) -> dict | None:
    if not path.exists():
        return None
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def scores(p: dict) -> dict:
    """Per posture and overall over the static people: (accuracy %, mean error cm, people)."""
    keep = p["trajectory"][:, 0] < 0
    r = class_scores(p["true_posture"][keep], p["pred_posture"][keep], p["true_xy"][keep], p["pred_xy"][keep])
    return {c: (r["accuracy"][c], r["error_cm"][c], r["people"][c]) for c in COLUMNS}


def seeds_of(args, net: str, policy: str) -> list[dict]:
    """Every seed's predictions of ``net`` under ``policy`` that exist."""
    found = []
    for seed in range(args.seeds):
        p = load(Path(NETS[net][1].format(bp=args.floor_net, runs=args.runs, seed=seed, policy=policy)))
        if p is not None:
            found.append(p)
    return found


def mean_sd(v: list[float]) -> tuple[float, float]:
    return float(np.mean(v)), float(np.std(v, ddof=1)) if len(v) > 1 else 0.0


def cell(ms: tuple[float, float], n: int, digits: int = 1) -> str:
    m, s = ms
    return f"{m:.{digits}f} ± {s:.{digits}f}" if n > 1 else f"{m:.{digits}f}"


def tracking(preds: list[dict]) -> dict:
    """Figure 5's numbers: mean error of the walks' frames raw and smoothed, per seed."""
    raw, smooth, tracks = [], [], []
    for p in preds:
        walk = p["trajectory"][:, 0] >= 0
        e_raw, e_s = [], []
        for room in np.unique(p["room"][walk]):
            sel = np.nonzero(walk & (p["room"] == room))[0]
            sel = sel[np.argsort(p["trajectory"][sel, 1])]
            xy = p["pred_xy"][sel]
            sm = smooth_trajectory(xy)
            e_raw.append(np.linalg.norm(xy - p["true_xy"][sel], axis=1))
            e_s.append(np.linalg.norm(sm - p["true_xy"][sel], axis=1))
            if len(tracks) < 4:
                tracks.append({"true": p["true_xy"][sel], "raw": xy, "smooth": sm,
                               "title": f"ours, unseen test room {int(room)} (seed 0)"})
        raw.append(100 * float(np.concatenate(e_raw).mean()))
        smooth.append(100 * float(np.concatenate(e_s).mean()))
    return {"raw_cm": raw, "smoothed_cm": smooth, "tracks": tracks}


def snr_table(path: Path | None) -> dict:
    if path is None or not path.exists():
        return {}
    with path.open() as f:
        return {r["policy"]: float(r["snr_fraction_mean"]) for r in csv.DictReader(f)}


def mean_answer_cm(args, preds: list[dict]) -> float:
    """The mean-position answer's error on the static test people (the training rooms' mean)."""
    xy = np.array(json.loads((args.floor_net / "t2-s0" / "run.json").read_text())["mean_xy"])
    p = preds[0]
    keep = p["trajectory"][:, 0] < 0
    return float(100 * np.linalg.norm(p["true_xy"][keep] - xy, axis=1).mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--floor-net", type=Path, default=Path("out/backprojection-net"), help="FloorNet runs (t2-sSEED)")
    ap.add_argument("--runs", type=Path, default=Path("out/unseen/runs-s2400"), help="experiments/unseen-rooms/unseen_rooms.py --runs")
    ap.add_argument("--snr", type=Path, default=Path("docs/results/unseen-geometry/spot-snr.csv"))
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--out", type=Path, default=Path("docs/results/unseen-paper"))
    args = ap.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    snr = snr_table(args.snr)
    lines = ["# Tables 1-3 on 40 unseen rooms (`experiments/paper-tables-unseen-rooms/unseen_paper_tables.py`)", ""]
    csv_rows = []
    got = {r.key: seeds_of(args, r.net, r.policy) for r in ROWS}
    if not got["ours"]:
        raise SystemExit(f"no predictions of ours under {args.floor_net} (run experiments/backprojection-across-rooms/backprojection_net.py with --ien)")
    chance = mean_answer_cm(args, got["ours"])
    per = {k: [scores(p) for p in v] for k, v in got.items() if v}
    for t, (title, j, unit) in enumerate((("Table 1: six-way posture accuracy (%)", 0, "%"),
                                          ("Table 2: localization error (cm)", 1, "cm")), 1):
        lines += [f"## {title}", "", "| method | seeds | " + " | ".join(COLUMNS) + " |",
                  "|---|---|" + "---|" * len(COLUMNS)]
        for r in ROWS:
            if r.key not in per:
                continue
            n = len(per[r.key])
            vals = [cell(mean_sd([s[c][j] for s in per[r.key]]), n) for c in COLUMNS]
            lines.append(f"| {r.label} | {n} | " + " | ".join(vals) + " |")
            for c in COLUMNS:
                csv_rows.append({"table": t, "method": r.key, "net": r.net, "policy": r.policy, "column": c,
                                 "mean": round(mean_sd([s[c][j] for s in per[r.key]])[0], 2),
                                 "sd": round(mean_sd([s[c][j] for s in per[r.key]])[1], 2), "seeds": n,
                                 "people": per[r.key][0][c][2]})
        lines += ["", f"Static people of the 40 test rooms ({per['ours'][0]['all'][2]}); chance 16.7% (six "
                      f"postures); the mean-position answer errs by {chance:.1f} cm.", ""]
    lines += ["## Table 3: spot policy x network (error cm / six-way %)", "",
              "| spot | SNR / oracle's | " + " | ".join(NETS[n][0] for n in GRID_NETS) + " |",
              "|---|---|" + "---|" * len(GRID_NETS)]
    grid = {}
    for pol in POLICIES:
        cells = []
        for net in GRID_NETS:
            s = [scores(p) for p in seeds_of(args, net, pol)]
            grid[pol, net] = s
            if not s:
                cells.append("")
                continue
            e, a = mean_sd([x["all"][1] for x in s]), mean_sd([x["all"][0] for x in s])
            cells.append(f"{cell(e, len(s))} / {a[0]:.1f}%")
            csv_rows.append({"table": 3, "method": f"{pol}+{net}", "net": net, "policy": pol, "column": "all",
                             "mean": round(e[0], 2), "sd": round(e[1], 2), "seeds": len(s),
                             "people": s[0]["all"][2]})
        lines.append(f"| {pol} | {snr.get(pol, float('nan')):.2f} | " + " | ".join(cells) + " |")
    tr = tracking(got["ours"])
    lines += ["", "## Figure 5: tracking (ours, the 40 walks of 20 frames)", "",
              f"Raw {cell(mean_sd(tr['raw_cm']), len(tr['raw_cm']))} cm, Savitzky-Golay smoothed "
              f"{cell(mean_sd(tr['smoothed_cm']), len(tr['smoothed_cm']))} cm (mean over frames; seeds).", ""]
    (args.out / "tables.md").write_text("\n".join(lines) + "\n")
    with (args.out / "tables.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, list(csv_rows[0]))
        w.writeheader()
        w.writerows(csv_rows)
    figures(args.out, tr, grid, chance)
    print("\n".join(lines))
    print(f"wrote {args.out}/tables.md, tables.csv, fig5_tracking.png, fig6_policies.png")


def figures(out: Path, tr: dict, grid: dict, chance: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from nlos_spotlight.evaluate.figures import tracking_figure

    tracking_figure(tr["tracks"], out / "fig5_tracking.png")  # the figure nlos evaluate draws
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
    width = 0.8 / len(GRID_NETS)
    for i, net in enumerate(GRID_NETS):
        x = np.arange(len(POLICIES)) + i * width
        for j, k in ((0, 1), (1, 0)):
            m = [np.mean([s["all"][k] for s in grid[p, net]]) if grid[p, net] else np.nan for p in POLICIES]
            ax[j].bar(x, m, width, label=NETS[net][0])
    ax[0].axhline(chance, color="k", ls="--", label="mean answer")
    ax[1].axhline(100 / 6, color="k", ls="--", label="chance")
    for a, lab in zip(ax, ("localization error (cm)", "six-way posture accuracy (%)")):
        a.set_xticks(np.arange(len(POLICIES)) + 0.4 - width / 2, POLICIES)
        a.set_ylabel(lab)
    ax[0].legend(fontsize=7)
    fig.suptitle("40 unseen rooms: spot policy x network", fontsize=9)
    fig.tight_layout()
    fig.savefig(out / "fig6_policies.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
