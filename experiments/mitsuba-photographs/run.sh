#!/usr/bin/env bash
# Held-out people of the copy room's default room model photographed by Mitsuba 3 (issue 35, item 3).
# The fit: about an hour on 2 cores; the Mitsuba photographs: hours on 2 cores (68 people at 32,768
# samples a pixel took 630 s on a 16-core machine); the robustness run: about an hour. Resumable
# except the render step (rerun it with --start for the people it did not reach). Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
MODEL=out/fits10/copyroom-default

$PY -m nlos_spotlight.cli fit --config benchmarks/configs/rooms/copyroom.yaml --out $MODEL --people 3000 --quiet
# the room, its spot's aim and the held-out people's bodies (here: the body model); --face 54 lets this
# run while the fit still renders (the spot the fit chose, checked by unpack)
$PY experiments/mitsuba-photographs/mitsuba_photographs.py export --model $MODEL --people 100 \
    --out out/mitsuba-bundle/copyroom
# anywhere Mitsuba runs (a GPU when there is one: --device auto); the committed photographs were
# rendered on a 16-core CPU in two runs (--start 0 --people 30, then --start 30 --people 38)
$PY experiments/mitsuba-photographs/mitsuba_photographs.py render --bundle out/mitsuba-bundle/copyroom \
    --spp 32768 --people 68 --out out/copyroom-mitsuba-d6-spp32768.npz
$PY experiments/mitsuba-photographs/mitsuba_photographs.py unpack --model $MODEL --room copyroom \
    --photographs docs/results/mitsuba-photographs/copyroom-d6-spp32768.npz --cache out/robustness10
$PY experiments/camera-photographs/robustness.py --model copyroom:default=$MODEL --people 68 --camera-draws 1 --noise-draws 5 \
    --bounce --photograph-bounce --mitsuba 32768 --mitsuba-people 68 --flag-captures 0 --magnitudes 2 \
    --cache out/robustness10 --out out/robustness10/copyroom-mitsuba.csv
# Mitsuba's photographs beside ours of the same people (robustness.py's cached camera photographs and bounce)
$PY experiments/mitsuba-photographs/mitsuba_photographs.py compare \
    --photographs docs/results/mitsuba-photographs/copyroom-d6-spp32768.npz \
    --camera out/robustness10/copyroom/camera-68-f8j-s8192.npz --bounce out/robustness10/copyroom/bounce-68-f8j-s4096-near1.npz \
    --out docs/results/mitsuba-photographs/copyroom-compare.txt
# the first 8 people at depth 4 (our three bounces and the shadow's relay: the physics ours renders), 8,192 samples a pixel
$PY experiments/mitsuba-photographs/mitsuba_photographs.py render --bundle out/mitsuba-bundle/copyroom --depth 4 \
    --spp 8192 --people 8 --device cpu --out out/copyroom-mitsuba-d4-spp8192.npz
$PY experiments/mitsuba-photographs/mitsuba_photographs.py compare \
    --photographs docs/results/mitsuba-photographs/copyroom-d4-spp8192.npz \
    --camera out/robustness10/copyroom/camera-68-f8j-s8192.npz --bounce out/robustness10/copyroom/bounce-68-f8j-s4096-near1.npz \
    --out docs/results/mitsuba-photographs/copyroom-compare-d4.txt
