"""Does a spot's SNR predict how well the fitted network reads posture under it?

The fit (``unseen_room_fit.py``) and the IEN choose the spot of highest SNR: the matched-filter
detectability of the person (``nlos_spotlight.lighting.snr``). Posture is a finer question than
detection, so SNR may be a poor proxy. Here every fitted room trained under several spots (ours,
SNR ranks 2-4, Adaptive Lighting's; the same simulated people, capture and training) gives one
point per other spot: the other spot's SNR over ours' against its six-way minus ours'. The SNR is
measured on the test room's own people (not the simulated people the fit chose from). If SNR is
the right proxy, the points slope upward and spots of much lower SNR read posture worse; if the
posture differences are flat in SNR, the choice among spots of similar SNR is a coin toss.

    python experiments/unseen-room-fit/spot_snr_posture.py --test out/unseen/test --fits out/unseen/room-fit-3000 \
        --base 16+e120+lux0 --others 16+e120+adaptive+lux0,16+e120+adaptive+lux0+s1 \
        16+e120+rank2+lux0,16+e120+rank2+lux0+s1 16+e120+rank3+lux0,16+e120+rank3+lux0+s1 16+e120+rank4+lux0 \
        16+e120+center+lux0,16+e120+center+lux0+s1 16+e120+center+lux0 \
        --out docs/results/unseen-room-fit-3000/spot-snr-posture.csv

A group joined by commas (training seeds) counts as its mean per room, against the mean of ours with
the same seeds ('--base V' with '+sN' appended for seed N): a room counts where every member and its
seed of ours were fitted. A face already counted in a room (an earlier group's) is not counted
again, so name a spot's seeds before its single seed. Writes the CSV (one row per room and other
spot) and prints the table, the least-squares slope of the six-way difference on log2 of the SNR
ratio with its standard error, and the mean difference by range of that ratio (:data:`BINS`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from nlos_spotlight.data.store import atomic_csv
from nlos_spotlight.errors import NlosError
from nlos_spotlight.evaluate.room_fits import parse_variant, read_fit_rows

COLUMNS = ["room", "base", "other", "base_face", "other_face", "base_snr", "other_snr", "oracle_snr",
           "other_rank", "seeds", "six_way_test_diff", "six_way_sim_diff", "error_sim_diff_cm"]


BINS = ((0.0, 0.25), (0.25, 0.75), (0.75, np.inf))
"""Ranges of the other spot's SNR over ours' the report averages within."""


def fitted_rows(fits: Path) -> dict:
    """{(variant, room, kind): row} of every room-fit CSV under ``fits`` (the largest people count
    where a variant was fitted with several)."""
    rows = {}
    for path in sorted(fits.glob("room-fit-*.csv")):
        try:
            for r in read_fit_rows(path):
                key = (r["variant"], r["room"], r["spot"].split(":")[0])
                if key not in rows or int(r["people"]) > int(rows[key]["people"]):
                    rows[key] = r
        except (KeyError, ValueError, TypeError, AttributeError) as exc:
            raise SystemExit(f"{path}: not a room-fit CSV ({type(exc).__name__}: {exc})") from None
    return rows


def group_score(rows: dict, group: list[str], room: str) -> dict | None:
    """The group's (seeds') mean six-way and error on the room's test and held-out people and its
    spot face, or None where any member is missing there (or the members lit different faces)."""
    got = [(rows.get((v, room, "fit")), rows.get((v, room, "heldout"))) for v in group]
    if any(f is None or h is None for f, h in got):
        return None
    faces = {f["spot"].split(":")[1] for f, _ in got}
    if len(faces) != 1:
        raise SystemExit(f"{room}: {','.join(group)} lit different faces {sorted(faces)}")
    mean = lambda i, k: float(np.mean([float(pair[i][k]) for pair in got]))
    return {"face": int(faces.pop()), "test": mean(0, "posture_accuracy"), "sim": mean(1, "posture_accuracy"),
            "err_sim": mean(1, "error_cm")}


def test_room_snr(test: Path, room: str) -> np.ndarray:
    """(T,) SNR of every candidate spot on the test room's own static people."""
    from nlos_spotlight.errors import NlosError
    from nlos_spotlight.lighting.snr import scene_snr

    try:
        return scene_snr(test / "scenes" / room).candidates
    except (NlosError, OSError, KeyError, ValueError) as exc:
        raise SystemExit(f"{test / 'scenes' / room}: cannot measure its spots' SNR ({exc})") from None


def same_seeds(base: str, group: list[str]) -> list[str]:
    """Ours' variants with the training seeds of ``group``'s (``base`` is seed 0's)."""
    seeds = [parse_variant(v).train_seed for v in group]
    return [base + (f"+s{s}" if s else "") for s in seeds]


def points(args) -> list[dict]:
    """One dict (:data:`COLUMNS`) per room and other spot fitted there beside ours' same seeds."""
    rows = fitted_rows(args.fits)
    rooms = sorted({room for _, room, _ in rows})
    out, snrs = [], {}
    for room in rooms:
        for spec in args.others:
            group = spec.split(",")
            base = same_seeds(args.base, group)
            ours, other = group_score(rows, base, room), group_score(rows, group, room)
            if ours is None or other is None:
                continue
            if other["face"] == ours["face"]:  # e.g. AL's heuristic picked ours' face: no other spot to compare
                print(f"{room}: {spec} lit ours' face {ours['face']}; left out")
                continue
            twin = [q for q in out if q["room"] == room and q["other_face"] == other["face"]]
            if twin:  # the same face: counted once, as the first group naming it (AL's spot is rank 2 there)
                print(f"{room}: {spec} lit face {other['face']} as {twin[0]['other']} did; counted once")
                continue
            if room not in snrs:
                snrs[room] = test_room_snr(args.test, room)
            snr = snrs[room]
            rank = int((snr > snr[other["face"]]).sum()) + 1
            out.append(dict(room=room, base=",".join(base), other=spec,
                            base_face=ours["face"], other_face=other["face"],
                            base_snr=f"{snr[ours['face']]:.4g}", other_snr=f"{snr[other['face']]:.4g}",
                            oracle_snr=f"{snr.max():.4g}", other_rank=rank, seeds=len(group),
                            six_way_test_diff=f"{other['test'] - ours['test']:.2f}",
                            six_way_sim_diff=f"{other['sim'] - ours['sim']:.2f}",
                            error_sim_diff_cm=f"{other['err_sim'] - ours['err_sim']:.2f}"))
    return out


def slope(x: np.ndarray, y: np.ndarray) -> str:
    """Least-squares slope of y on x with its standard error."""
    if len(x) < 3 or np.ptp(x) == 0:
        return "n/a"
    X = np.stack([np.ones_like(x), x], 1)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    resid = y - X @ coef
    cov = resid @ resid / (len(x) - 2) * np.linalg.inv(X.T @ X)
    return f"{coef[1]:+.1f} +- {np.sqrt(cov[1, 1]):.1f}"


def ratio(p: dict) -> float:
    """A point's other spot's SNR over ours'."""
    return float(p["other_snr"]) / float(p["base_snr"])


def report(pts: list[dict]) -> list[str]:
    """The points' table, the slope of six-way on log2 SNR ratio, and the means by ratio range."""
    lines = ["| room | other spot | seeds | faces (ours, other) | SNR over ours' (test people) | other's SNR rank | "
             "six-way minus ours (test / simulated) | error minus ours (simulated) |", "|---" * 8 + "|"]
    for p in pts:
        shown = f"{ratio(p):.2f}" if ratio(p) >= 0.1 else f"{ratio(p):.2g}"  # a dark corner's spot: 0.0014, not 0.00
        lines.append(f"| {p['room']} | {p['other'].split(',')[0]} | {p['seeds']} | {p['base_face']}, "
                     f"{p['other_face']} | {shown} | {p['other_rank']} | {float(p['six_way_test_diff']):+.1f} / "
                     f"{float(p['six_way_sim_diff']):+.1f} | {float(p['error_sim_diff_cm']):+.1f} cm |")
    x = np.log2([ratio(p) for p in pts])
    for kind, key in (("test", "six_way_test_diff"), ("simulated", "six_way_sim_diff")):
        y = np.array([float(p[key]) for p in pts])
        lines.append(f"Six-way minus ours on the {kind} people against log2(SNR over ours'), {len(pts)} points: slope "
                     f"{slope(x, y)} points per doubling of SNR; mean {y.mean():+.1f}.")
    for lo, hi in BINS:
        sel = [p for p in pts if lo <= ratio(p) < hi]
        if sel:
            mean = lambda key: np.mean([float(p[key]) for p in sel])
            span = f"{lo:g}-{hi:g}x" if np.isfinite(hi) else f"at least {lo:g}x"
            rooms = len({p["room"] for p in sel})
            xs = np.log2([ratio(p) for p in sel])
            within = " / ".join(slope(xs, np.array([float(p[k]) for p in sel]))
                                for k in ("six_way_test_diff", "six_way_sim_diff"))
            lines.append(f"Other spot of {span} ours' SNR ({len(sel)} points, {rooms} rooms): six-way minus ours "
                         f"{mean('six_way_test_diff'):+.1f} / {mean('six_way_sim_diff'):+.1f} (test / simulated), "
                         f"error {mean('error_sim_diff_cm'):+.1f} cm (simulated); slope within the range {within} "
                         "points per doubling.")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--test", type=Path, required=True, help="test dataset (unseen-test.yaml)")
    ap.add_argument("--fits", type=Path, required=True, help="unseen_room_fit.py --out folder (room-fit-*.csv)")
    ap.add_argument("--base", required=True,
                    help="ours, seed 0 (e.g. 16+e120+lux0; its '+sN' variants are the seeds)")
    ap.add_argument("--others", nargs="+", required=True, metavar="GROUP",
                    help="the other spots' variants, training seeds joined by commas")
    ap.add_argument("--out", type=Path, default=None, help="CSV of the points")
    args = ap.parse_args()
    pts = points(args)
    if not pts:
        raise SystemExit(f"{args.fits}: no room fitted with {args.base} and any of {' '.join(args.others)}")
    print("\n".join(report(pts)))
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        atomic_csv(args.out, COLUMNS, pts)


if __name__ == "__main__":
    try:
        main()
    except NlosError as exc:  # a malformed variant or room range: one line
        raise SystemExit(f"error: {exc}") from None
