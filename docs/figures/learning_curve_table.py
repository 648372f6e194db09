"""Render a learning-curve CSV as the markdown table of docs/results.md (rerun after the curve).

    python docs/figures/learning_curve_table.py [docs/results/per-room/learning-curve.csv]
"""

import csv
import sys
from pathlib import Path

path = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).parent.parent / "results" / "learning-curve.csv"
rows = list(csv.DictReader(path.open()))
print("| capture | spot | people/room | network | posture (6) | upright/sitting/crouching | error | CRB "
      "| error / CRB |")
print("|---|---|---|---|---|---|---|---|---|")
for r in rows:
    crb = float(r["crb_cm"]) if r["crb_cm"] else None
    ratio = f"{float(r['error_cm']) / crb:.1f}x" if crb else ""
    print(f"| {r['capture']} | {r['policy']} | {r['people_per_room']} | {r['arch']} "
          f"| {float(r['posture_accuracy']):.1f}% "
          f"| {float(r['posture3_accuracy']):.1f}% | {float(r['error_cm']):.1f} cm | "
          f"{f'{crb:.1f} cm' if crb else ''} | {ratio} |")
