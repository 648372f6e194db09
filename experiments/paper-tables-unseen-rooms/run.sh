#!/usr/bin/env bash
# The paper's Tables 1-3 on 40 unseen rooms (README.md). Reads the predictions of
# experiments/backprojection-across-rooms and experiments/unseen-rooms' runs; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY experiments/paper-tables-unseen-rooms/unseen_paper_tables.py --out docs/results/unseen-paper
