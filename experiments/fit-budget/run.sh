#!/usr/bin/env bash
# How long to train a room model (README.md). Needs the copy room's fit, out/fits/copyroom; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY experiments/fit-budget/fit_budget.py out/fits/copyroom --epochs 10,30
