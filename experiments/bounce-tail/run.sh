#!/usr/bin/env bash
# Every bounce past the fourth in a photograph, split into the light off the body and the light the
# body stops, by Mitsuba 3 against ours (issue 35). The reference scenes: about 5 minutes on 2 cores.
# The copy room: its default room model's first 8 held-out people (experiments/mitsuba-photographs:
# the fit, then `export`), Mitsuba at depth 4 and 10, the photograph and the light the body stops
# (about 25 minutes on 2 cores), ours rendered here (1.5 minutes). Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
M=docs/results/mitsuba-photographs

$PY experiments/bounce-tail/bounce_tail.py scenes --spp 32768 --out docs/results/bounce-tail/scenes.txt
# (the 8,192-sample photographs at depth 4 were rendered in session 10; the same seeds at depth 10)
for d in 4 10; do
  [ -f $M/copyroom-d$d-spp8192.npz ] || $PY experiments/mitsuba-photographs/mitsuba_photographs.py render \
      --bundle out/mitsuba-bundle/copyroom --depth $d --spp 8192 --people 8 --device cpu --out $M/copyroom-d$d-spp8192.npz
  [ -f $M/copyroom-blocked-d$d-spp8192.npz ] || $PY experiments/mitsuba-photographs/mitsuba_photographs.py render \
      --bundle out/mitsuba-bundle/copyroom --depth $d --protocol blocked --spp 8192 --people 8 --device cpu \
      --out $M/copyroom-blocked-d$d-spp8192.npz
done
$PY experiments/bounce-tail/bounce_tail.py room --mitsuba $M --room copyroom --spp 8192 \
    --camera out/robustness10/copyroom/camera-68-f8j-s8192.npz --bounce out/robustness10/copyroom/bounce-68-f8j-s4096-near1.npz \
    --bundle out/mitsuba-bundle/copyroom --out docs/results/bounce-tail/copyroom.txt
# what the shadow to depth 10 costs a person, beside depth 4
$PY experiments/bounce-tail/bounce_tail.py cost --bundle out/mitsuba-bundle/copyroom --people 6 --out docs/results/bounce-tail/cost.txt
# the copy room's default refitted with the shadow to depth 10 (only the shadow rendered again: about
# 45 min on 2 cores), then read on the camera photographs (the cached ones of experiments/mitsuba-photographs)
$PY -m nlos_spotlight.cli fit --config benchmarks/configs/rooms/copyroom.yaml --out out/fits11/copyroom-default \
    --people 3000 --people-from out/fits10/copyroom-default --clothing camera --quiet  # the default until session 14
$PY experiments/camera-photographs/robustness.py --model copyroom:default=out/fits11/copyroom-default --people 68 --camera-draws 1 --noise-draws 5 \
    --bounce --photograph-bounce --shadow-depth 10 --mitsuba 32768 --mitsuba-people 68 --flag-captures 0 --magnitudes 2 \
    --cache out/robustness10 --out out/robustness12/copyroom.csv
