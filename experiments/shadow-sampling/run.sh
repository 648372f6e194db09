#!/usr/bin/env bash
# The default refitted at the demo's shadow sampling (2,048 relay points, 256 bounce body samples; the
# shadow step rendered again: about 45 min on 2 cores), then read on the camera photographs. Needs
# experiments/bounce-tail's refit and the cached photographs of experiments/mitsuba-photographs. Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY -m nlos_spotlight.cli fit --config benchmarks/configs/rooms/copyroom.yaml --out out/fits12/copyroom-fast --people 3000 \
    --people-from out/fits11/copyroom-default --shadow-samples 2048 --bounce-body-samples 256 --quiet
$PY experiments/camera-photographs/robustness.py --model copyroom:fast=out/fits12/copyroom-fast --people 68 --camera-draws 1 --noise-draws 5 \
    --bounce --photograph-bounce --shadow-depth 10 --mitsuba 32768 --mitsuba-people 68 --flag-captures 0 --magnitudes 2 \
    --cache out/robustness10 --out out/robustness12/copyroom-fast.csv
