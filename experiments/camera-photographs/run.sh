#!/usr/bin/env bash
# Room models on photographs a camera could take (issue 35): the pixel's exact mean (jittered
# footprints), the person's light over one more bounce, a scan's smooth warp. Hours on 2 cores;
# every step resumes. Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
ROOMS=benchmarks/configs/rooms

# the default recipe (grid footprints), the copy room and the living room: 3,000 people each
$PY experiments/people-curve/people_curve.py --rooms copyroom,icl_livingroom2 --people 3000 --out out/people-curve2 \
    --csv out/people-curve2/people-curve.csv --quiet
# the same copy room with jittered footprints (a draw per set of people), and with the fifth bounce
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/fits7/copyroom-jitter --people 3000 \
    --footprint jittered --quiet
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/fits7/copyroom-bounce --people 3000 \
    --people-from out/people-curve2/copyroom-3000 --bounce on --bounce-scale 1 --bounce-body-samples 0 --quiet
# read on camera photographs (jittered 8 x 8, 4 draws averaged), with the fifth bounce, under drift
$PY experiments/camera-photographs/robustness.py --model copyroom:relay=out/people-curve2/copyroom-3000 \
    --model copyroom:jitter=out/fits7/copyroom-jitter --camera-draws 4 --noise-draws 5 --bounce \
    --cache out/robustness7 --out out/robustness7/copyroom-ab.csv
$PY experiments/camera-photographs/robustness.py --model copyroom:bounce=out/fits7/copyroom-bounce --camera-draws 4 --noise-draws 5 \
    --bounce --cache out/robustness7 --out out/robustness7/copyroom-bounce.csv
$PY experiments/camera-photographs/robustness.py --model livingroom:before=out/fits/livingroom-before \
    --model livingroom:relay=out/people-curve2/icl_livingroom2-3000 --camera-draws 4 --noise-draws 5 --bounce \
    --cache out/robustness7 --out out/robustness7/livingroom.csv
# a scan's geometry error: 2 mm per vertex and a 1 cm smooth warp (tripod)
$PY experiments/camera-photographs/robustness.py --model copyroom:relay=out/people-curve2/copyroom-3000 --world-magnitudes 1 \
    --world-effects geometry,warp --world-only --noise-draws 5 --cache out/robustness7 --out out/robustness7/copyroom-world.csv
# session 8: the drift fit holds the people's light (added to the model by --resume), the bounce models,
# the bounce's near field
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/people-curve2/copyroom-3000 --people 3000 \
    --device cpu --resume --quiet
# the drift fit's person directions (docs/results/drift-directions.csv), archived: git show
# archive/studies-2026-11-29:benchmarks/drift_directions.py > drift_directions.py, then run it beside experiments/camera-photographs/robustness.py
$PY experiments/camera-photographs/robustness.py --model copyroom:relay=out/people-curve2/copyroom-3000 --no-render --noise-draws 1 \
    --magnitudes 2 --out out/robustness8/copyroom-flags-only.csv
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/fits8/copyroom-bounce19 --people 3000 \
    --people-from out/fits7/copyroom-bounce --bounce on --bounce-scale 1.9 --bounce-body-samples 0 --quiet
$PY experiments/camera-photographs/robustness.py --model copyroom:bounce=out/fits7/copyroom-bounce \
    --model copyroom:bounce19=out/fits8/copyroom-bounce19 --camera-draws 4 --noise-draws 5 --bounce --flag-captures 0 \
    --magnitudes 2 --cache out/robustness7 --out out/robustness8/copyroom-bounce-fixed.csv
$PY benchmarks/bounce_mitsuba.py --spp 32768 --res 16 --tail 10 --out docs/results/bounce-mitsuba.txt
$PY benchmarks/bounce_relay_spread.py --model out/people-curve2/copyroom-3000 --people 12 \
    --out docs/results/bounce-relay-spread.txt
$PY experiments/camera-photographs/robustness.py --model copyroom:relay=out/people-curve2/copyroom-3000 --camera-draws 4 --noise-draws 5 \
    --bounce --flag-captures 0 --magnitudes 2 --cache out/robustness7 --out out/robustness8/copyroom-relay-near.csv
# the bounce rendered again with the distance floor (its shadow step renders again), read on the floored photographs
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/fits8/copyroom-near --people 3000 \
    --people-from out/fits7/copyroom-bounce --bounce on --bounce-scale 1 --bounce-body-samples 0 --quiet
$PY experiments/camera-photographs/robustness.py --model copyroom:near=out/fits8/copyroom-near \
    --model copyroom:relay=out/people-curve2/copyroom-3000 --camera-draws 4 --noise-draws 5 --bounce --flag-captures 0 \
    --magnitudes 2 --cache out/robustness7 --out out/robustness8/copyroom-near.csv
# session 9: the floored bounce at x1.9 (now nlos fit's default), the bounce through 1,024 body samples, the default refit
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/fits8/copyroom-near19 --people 3000 \
    --people-from out/fits8/copyroom-near --bounce on --bounce-scale 1.9 --bounce-body-samples 0 --quiet
$PY experiments/camera-photographs/robustness.py --model copyroom:near=out/fits8/copyroom-near --model copyroom:near19=out/fits8/copyroom-near19 \
    --camera-draws 4 --noise-draws 5 --bounce --flag-captures 0 --magnitudes 2 --cache out/robustness7 \
    --out out/robustness8/copyroom-near.csv
$PY benchmarks/bounce_body_samples.py --model out/people-curve2/copyroom-3000 --people 8 --samples 1024,512,256 \
    --out docs/results/bounce-body-samples.txt
$PY -m nlos_spotlight.cli fit --config $ROOMS/copyroom.yaml --out out/fits9/copyroom-default --people 3000 \
    --people-from out/fits8/copyroom-near --quiet
$PY experiments/camera-photographs/robustness.py --model copyroom:bounce=out/fits8/copyroom-near19 --model copyroom:relay=out/people-curve2/copyroom-3000 \
    --camera-draws 4 --noise-draws 5 --bounce --photograph-bounce --flag-captures 200 --flag-multiples 1,2 \
    --cache out/robustness7 --out out/robustness9/copyroom.csv
$PY experiments/camera-photographs/robustness.py --model copyroom:default=out/fits9/copyroom-default --camera-draws 4 --noise-draws 5 --bounce \
    --photograph-bounce --flag-captures 0 --magnitudes 2 --cache out/robustness7 --out out/robustness9/copyroom-default.csv
# next: the living room and the office under the default (about 1-2 h each on 2 cores, resumable)
$PY -m nlos_spotlight.cli fit --config $ROOMS/icl_office2.yaml --out out/fits9/office-default --people 1500 \
    --people-from out/fits3/office --quiet
