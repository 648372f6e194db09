#!/usr/bin/env bash
# Dark clothing (issue 35): the copy room's default trained again with dark clothing 4x as often
# (--clothing camera-log; nothing rendered again: about 11 minutes on 2 cores), then both models read
# the same camera photographs (about 4 minutes each). Needs experiments/bounce-tail's refit
# (out/fits11/copyroom-default) and the cached photographs of experiments/mitsuba-photographs. Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY -m nlos_spotlight.cli fit --config benchmarks/configs/rooms/copyroom.yaml --out out/fits11/copyroom-clothlog \
    --people 3000 --people-from out/fits11/copyroom-default --clothing camera-log --quiet
for m in default clothlog; do
  $PY experiments/camera-photographs/robustness.py --model copyroom:$m=out/fits11/copyroom-$m --people 68 --camera-draws 1 --noise-draws 5 \
      --bounce --photograph-bounce --shadow-depth 10 --mitsuba 32768 --mitsuba-people 68 --flag-captures 0 --magnitudes 2 \
      --cache out/robustness10 --out out/robustness12/copyroom-$m.csv
done

# Session 14: the three scans, 100 held-out people each. The living room and the office trained again
# in camera-log clothing on experiments/three-rooms' fits (--clothing camera: the uniform draw, the
# default before this study); the copy room's fits are session 12's, above. Their cached photographs
# (out/robustness13, out/robustness10) are read again, nothing of them rendered again but the copy
# room's 100 people.
for ROOM in livingroom:icl_livingroom2 office:icl_office2; do
  NAME=${ROOM%%:*}; SCAN=${ROOM#*:}
  $PY -m nlos_spotlight.cli fit --config benchmarks/configs/rooms/$SCAN.yaml --out out/fits14/$NAME-clothlog \
      --people 1500 --people-from out/fits13/$NAME-default --clothing camera-log --quiet
  $PY experiments/camera-photographs/robustness.py --model $NAME:clothlog=out/fits14/$NAME-clothlog --people 100 --camera-draws 1 \
      --noise-draws 5 --bounce --photograph-bounce --shadow-depth 10 --mitsuba 0 --flag-captures 0 \
      --magnitudes 0.5,1,2 --cache out/robustness13 --out out/robustness14/$NAME-clothlog.csv
done
$PY experiments/camera-photographs/robustness.py --model copyroom:default=out/fits11/copyroom-default \
    --model copyroom:before=out/fits10/copyroom-default --people 100 --camera-draws 1 --noise-draws 5 --bounce \
    --photograph-bounce --shadow-depth 10 --mitsuba 0 --flag-captures 0 --magnitudes 0.5,1,2 \
    --cache out/robustness10 --out out/robustness14/copyroom.csv
$PY experiments/camera-photographs/robustness.py --model copyroom:clothlog=out/fits11/copyroom-clothlog --people 100 --camera-draws 1 \
    --noise-draws 5 --bounce --photograph-bounce --shadow-depth 10 --mitsuba 0 --flag-captures 0 \
    --magnitudes 0.5,1,2 --cache out/robustness10 --out out/robustness14/copyroom-clothlog.csv
$PY experiments/dark-clothing/gather_rows.py --take out/robustness14/copyroom.csv:default=shadow10-uniform \
    --take out/robustness14/copyroom-clothlog.csv:clothlog=shadow10-log \
    --take out/robustness13/livingroom.csv:default=shadow10-uniform \
    --take out/robustness14/livingroom-clothlog.csv:clothlog=shadow10-log \
    --take out/robustness13/office.csv:default=shadow10-uniform \
    --take out/robustness14/office-clothlog.csv:clothlog=shadow10-log --out docs/results/robustness.csv
