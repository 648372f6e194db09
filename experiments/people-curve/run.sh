#!/usr/bin/env bash
# The per-room fit against people per room (issue 38, item 4): one nlos fit per room and count, resumable;
# 29.2 min for 3,000 people in the copy room on 2 cores (docs/results.md, Speed). Not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY experiments/people-curve/people_curve.py --rooms copyroom --people 3000,6000 --quiet
