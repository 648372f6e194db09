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
  $PY benchmarks/robustness.py --model copyroom:$m=out/fits11/copyroom-$m --people 68 --camera-draws 1 --noise-draws 5 \
      --bounce --photograph-bounce --shadow-depth 10 --mitsuba 32768 --mitsuba-people 68 --flag-captures 0 --magnitudes 2 \
      --cache out/robustness10 --out out/robustness12/copyroom-$m.csv
done
