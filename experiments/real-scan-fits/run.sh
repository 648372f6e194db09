#!/usr/bin/env bash
# nlos fit on the three real scans (README.md): 25.2 / 26.9 / 26.5 min a room on 2 cores; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY experiments/real-scan-fits/real_scan_fits.py
