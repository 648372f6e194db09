#!/usr/bin/env bash
# What the physics allows (README.md). Needs out/lc/data with the learning curve's runs and out/unseen/test;
# not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
HERE=experiments/physics-bounds

$PY $HERE/position_crb.py --data out/lc/data --people 8
$PY $HERE/posture_separability.py --data out/lc/data --people 4
$PY $HERE/posture_separability.py --data out/unseen/test --split test --people 3 \
    --json docs/results/posture-ceiling-unseen.json
