"""Turn an :class:`Evaluation` into files: CSVs, figures, report.md and report.html."""

from __future__ import annotations

import json
import platform
from pathlib import Path

import numpy as np
import torch

from ..data.store import atomic_csv
from ..world.body import POSTURES
from . import figures
from .experiment import PAPER, Evaluation
from .methods import BY_NAME, TABLE3
from .metrics import COLUMNS, aggregate, fmt, per_class
from .report import Block, write_report


def _atomic_csv(path: Path, header: list[str], rows: list[list]) -> None:
    """List rows under ``header`` through the package's one atomic CSV writer."""
    atomic_csv(path, header, [dict(zip(header, r)) for r in rows])


def write_raw(ev: Evaluation, out: Path) -> None:
    rows = []
    for name, by_seed in ev.preds.items():
        for seed, p in by_seed.items():
            a = p.arrays()
            for i in range(len(p.scene)):
                ill = p.spots[p.scene[i]]
                rows.append([name, seed, p.scene[i], p.sample[i], *a["trajectory"][i], ill.mode, ill.face,
                             *np.round(a["true_xy"][i], 5), *np.round(a["pred_xy"][i], 5), POSTURES[a["true_posture"][i]],
                             POSTURES[int(a["probs"][i].argmax())], *np.round(a["probs"][i], 5)])
    _atomic_csv(out / "raw.csv", ["method", "seed", "scene", "sample", "trajectory", "frame", "illumination", "face",
                                  "true_x", "true_y", "pred_x", "pred_y", "true_posture", "pred_posture",
                                  *[f"p_{c}" for c in POSTURES]], rows)


def results(ev: Evaluation, seen: bool = False) -> dict:
    """method -> metric -> column -> (mean, std) over seeds, on unseen rooms (or seen ones)."""
    preds = ev.seen if seen else ev.preds
    return {name: aggregate([per_class(p) for p in by_seed.values()]) for name, by_seed in preds.items()}


def write_summary(ev: Evaluation, out: Path) -> None:
    rows = []
    for name, by_seed in ev.preds.items():
        for seed, p in by_seed.items():
            r = per_class(p)
            rows += [[name, seed, metric, col, round(r[metric][col], 4)] for metric in r for col in COLUMNS]
    for name, by_seed in ev.seen.items():
        for seed, p in by_seed.items():
            r = per_class(p)
            rows += [[name, seed, f"{metric}_seen_rooms", col, round(r[metric][col], 4)] for metric in r
                     for col in COLUMNS]
    for i, seed in enumerate(ev.seeds):
        for j, ratio in enumerate(ev.decimation.get("ratios", [])):
            rows.append(["ours_decimated", seed, "accuracy", f"ratio={ratio}", ev.decimation["accuracy"][i][j]])
            rows.append(["ours_decimated", seed, "error_cm", f"ratio={ratio}", ev.decimation["error_cm"][i][j]])
    for name, (m, s) in ev.snr.items():
        rows.append([name, "all", "snr_over_oracle", "mean", round(m, 4)])
    _atomic_csv(out / "summary.csv", ["method", "seed", "metric", "column", "value"], rows)


def tracks(ev: Evaluation, limit: int = 3) -> list[dict]:
    """Fig. 5 panels: walks of held-out people in the training rooms (seen rooms, where the networks
    learn) first, then walks in the unseen test rooms."""
    out = []
    for preds, where in ((ev.seen.get("ours", {}), "seen room"), (ev.preds.get("ours", {}), "new room")):
        if ev.seeds and ev.seeds[0] in preds:
            out += _tracks_of(preds[ev.seeds[0]], where, limit - len(out))
        if len(out) >= limit:
            break
    return out


def _tracks_of(p, where: str, limit: int) -> list[dict]:
    from .tracking import smooth_trajectory

    a = p.arrays()
    out = []
    if limit <= 0 or not len(p.scene):
        return out
    for sid in dict.fromkeys(p.scene):
        sel = np.array([s == sid for s in p.scene])
        for tid in sorted(set(a["trajectory"][sel, 0]) - {-1}):
            k = np.flatnonzero(sel & (a["trajectory"][:, 0] == tid))
            k = k[np.argsort(a["trajectory"][k, 1])]
            raw = a["pred_xy"][k]
            window = min(len(k) - (1 - len(k) % 2), 9)
            if window < 5:
                continue
            out.append({"true": a["true_xy"][k], "raw": raw, "smooth": smooth_trajectory(raw, window, 2),
                        "title": f"{sid} ({where}), walk {tid} ({len(k)} frames)"})
            if len(out) == limit:
                return out
    return out


def policy_panels(ev: Evaluation, data: Path) -> list[dict]:
    """Fig. 6: one test scene, its first sample, under each method's illumination (one per policy)."""
    from ..render.camera import project
    from ..scene import load_scene
    from ..train.imaging import form_images
    from ..data.static import read_static
    from ..data.tensors import load_scene_tensors

    sid = ev.scene_ids[0]
    s = load_scene_tensors(data / "scenes" / sid, ["normals"])
    cam = load_scene(data / "scenes" / sid).camera
    aims = read_static(data / "scenes" / sid, "aim_points")["aim_points"]
    panels, seen = [], set()
    for name, by_seed in ev.preds.items():
        m = BY_NAME[name]
        if m.policy in seen:
            continue
        seen.add(m.policy)
        ill = by_seed[ev.seeds[0]].spots[sid]
        img, free = form_images(s, torch.tensor([0]), ill.spot_vector(len(s.faces)), ill.mode)
        spot = project(cam, aims[ill.face][None])[0] if ill.mode == "spot" else None
        label = {"ien": "IEN (ours)", "adaptive": "Adaptive Lighting"}.get(m.policy, m.policy.capitalize())
        panels.append({"name": label, "image": img[0].numpy(), "nlos": (img[0] - free).numpy(), "spot": spot})
    return panels


def table(res: dict, names: list[str], metric: str, digits: int) -> Block:
    header = ["method", *COLUMNS]
    rows = [[BY_NAME[n].label, *[fmt(res[n][metric][c], digits) for c in COLUMNS]] for n in names if n in res]
    return Block("table", header=header, rows=rows)


def build(ev: Evaluation, data: Path, run_dir: Path, out: Path, command: str) -> list[Block]:
    res = results(ev)
    names = list(res)
    b = [Block("h1", "nlos-spotlight evaluation"),
         Block("p", f"Run {run_dir}, data {data}, {len(ev.scene_ids)} held-out test scenes "
                    + (f"of {ev.test_data} " if ev.test_data and ev.test_data != data else "") +
                    f"({', '.join(ev.scene_ids)}), training seeds {ev.seeds}. Every number is mean ± std over "
                    "seeds; images are formed from the stored light transport under each method's illumination "
                    "and pass through the sensor model (auto-exposure, shot, read and quantization noise)."),
         Block("code", command)]
    if ev.skipped:
        b.append(Block("p", "Not run: " + "; ".join(f"{k} ({v})" for k, v in ev.skipped.items()) + "."))
    b += [Block("h2", "Table 1: posture accuracy (%) per class"), table(res, names, "accuracy", 1),
          Block("h2", "Table 2: mean localization error (cm) per class"), table(res, names, "error_cm", 1),
          Block("h2", "Table 3: spot policy and network ablation"),
          Block("table", header=["method", "posture accuracy (%)", "localization error (cm)"],
                rows=[[BY_NAME[n].label, fmt(res[n]["accuracy"]["all"]), fmt(res[n]["error_cm"]["all"])]
                      for n in TABLE3 if n in res])]
    if ev.seen:
        seen = results(ev, seen=True)
        n = sum(len(p.scene) for p in next(iter(ev.seen.values())).values()) // len(ev.seeds)
        b += [Block("h2", "Seen rooms: new people in the training rooms"),
              Block("p", f"The same trained models on the {n} static samples held out of the "
                         f"{len(ev.seen_ids)} training rooms (every n-th, TrainConfig.holdout_every): new "
                         "positions, postures, bodies and noise in rooms the networks trained in, the setting "
                         "of a user who scans their room and trains for it. Fixed policies keep their "
                         "training spot there."),
              Block("table", header=["method", "posture accuracy (%)", "localization error (cm)"],
                    rows=[[BY_NAME[k].label, fmt(v["accuracy"]["all"]), fmt(v["error_cm"]["all"])]
                          for k, v in seen.items()])]
    if ev.snr:
        b += [Block("h2", "Spot quality: NLOS SNR of each method's spot over the oracle's"),
              Block("p", "Per test scene, the matched-filter SNR of the person's signal under the sensor noise "
                         "(mean over the scene's static samples) for the chosen spot, divided by the best "
                         "candidate's; mean ± std over scenes and seeds."),
              Block("table", header=["method", "SNR / oracle SNR"],
                    rows=[[BY_NAME[n].label, fmt(v, 3)] for n, v in ev.snr.items()])]
    ours = res.get("ours")
    if ours:
        seen = results(ev, seen=True).get("ours")
        col = lambda m: [fmt(ours[m]["all"])] + ([fmt(seen[m]["all"])] if seen else [])
        b += [Block("h2", "Against the paper"),
              Block("table", header=["", "paper (synthetic)", "this run, unseen rooms"]
                    + (["this run, seen rooms"] if seen else []),
                    rows=[["posture accuracy (%)", f"{PAPER['accuracy']}", *col("accuracy")],
                          ["localization error (cm)", f"{PAPER['error_cm']}", *col("error_cm")]]),
              Block("p", "The paper's numbers come from its own synthetic set (30 hand-built scenes with "
                         "augmentation, 256x256 renders); ours from procedural rooms at the resolution and scale "
                         "of this dataset's config, so the comparison is of trends, not of equal conditions.")]
    tr = tracks(ev)
    if tr:
        figures.tracking_figure(tr, out / "fig5_tracking.png")
        b += [Block("h2", "Figure 5: tracking"),
              Block("image", "Fig. 5: walking trajectories, ground truth, raw per-frame estimates of ours and their "
                             "Savitzky-Golay smoothing (scipy.signal.savgol_filter, order 2), mean error in the "
                             "legend.", image="fig5_tracking.png")]
    figures.policy_figure(policy_panels(ev, ev.test_data or data), out / "fig6_policies.png")
    b += [Block("h2", "Figure 6: each policy's illumination on one scene"),
          Block("image", f"Fig. 6: scene {ev.scene_ids[0]}, sample 0, noise-free. Top: the photograph (+ marks "
                         "the spot's aim point); bottom: the light the person adds.", image="fig6_policies.png")]
    d = ev.decimation
    if d:
        figures.decimation_figure(d["ratios"], np.array(d["accuracy"]), np.array(d["error_cm"]),
                                  out / "fig7_decimation.png")
        b += [Block("h2", "Figure 7: robustness to mesh decimation"),
              Block("image", f"Fig. 7: ours, with the IEN reading the camera-visible surface remeshed to "
                             f"{d['dense_vertices']} vertices and decimated (quadric edge collapse) to each ratio; "
                             f"chosen centroids snap to the stored candidates (mean snap {100 * d['snap_m_mean']:.1f}"
                             " cm).", image="fig7_decimation.png")]
    b += [Block("h2", "Files"),
          Block("p", "raw.csv: every prediction of every method and seed; summary.csv: every table number per "
                     "seed; evaluation.json: config, seeds, versions and timings; runs under RUN/methods/.")]
    return b


def write_all(ev: Evaluation, data: Path, run_dir: Path, out: Path, command: str) -> Path:
    from ..data.generate import versions

    out.mkdir(parents=True, exist_ok=True)
    write_raw(ev, out)
    write_summary(ev, out)
    blocks = build(ev, data, run_dir, out, command)
    md, _ = write_report(blocks, out, "nlos-spotlight evaluation")
    meta = {"command": command, "run": str(run_dir), "data": str(data), "test_data": str(ev.test_data or data),
            "seeds": ev.seeds,
            "methods": [m.name for m in ev.methods], "skipped": ev.skipped, "seconds": ev.seconds,
            "results": results(ev), "results_seen_rooms": results(ev, seen=True), "seen_rooms": ev.seen_ids,
            "spot_snr_over_oracle": ev.snr, "decimation": ev.decimation,
            "versions": versions(), "platform": platform.platform()}
    tmp = out / ".evaluation.json.tmp"
    tmp.write_text(json.dumps(meta, indent=1))
    tmp.replace(out / "evaluation.json")
    return md
