#!/usr/bin/env bash
# Does the spot matter? (README.md). Needs out/unseen/test for the last three; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
NLOS=.venv/bin/nlos
HERE=experiments/spot-matters

$NLOS generate benchmarks/configs/sensor-snr.yaml --out out/snr/data
$PY $HERE/spot_matters.py --data out/snr/data --split train
$PY $HERE/spot_matters.py --data out/unseen/test --split test --rooms 14 \
    --json docs/results/spot-matters-unseen.json > docs/results/spot-matters-unseen.txt
$PY $HERE/spot_matters.py --data out/unseen/test --split test --rooms 4 \
    --json docs/results/spot-matters-unseen-0-3.json > docs/results/spot-matters-unseen-0-3.txt
$PY $HERE/spot_matters.py --data out/unseen/test --split test --adaptive \
    --json docs/results/spot-matters-unseen-adaptive.json
