#!/usr/bin/env bash
# Today's default room model in the two other scans of issue 35 (ICL living room, ICL office), read on
# camera photographs of 100 held-out people each, beside the copy room's (experiments/bounce-tail).
# 1,500 people a room (half the default's, to fit both in one session): about 65 min a fit on 2
# free cores since session 13's shadow step, and about 20 min a robustness run. Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
for ROOM in livingroom:icl_livingroom2 office:icl_office2; do
  NAME=${ROOM%%:*}; SCAN=${ROOM#*:}
  $PY -m nlos_spotlight.cli fit --config benchmarks/configs/rooms/$SCAN.yaml --out out/fits13/$NAME-default \
      --people 1500 --clothing camera --quiet  # uniform clothing: the default until session 14
  $PY experiments/camera-photographs/robustness.py --model $NAME:default=out/fits13/$NAME-default --people 100 --camera-draws 1 \
      --noise-draws 5 --bounce --photograph-bounce --shadow-depth 10 --mitsuba 0 --flag-captures 0 \
      --magnitudes 0.5,1,2 --cache out/robustness13 --out out/robustness13/$NAME.csv
done
