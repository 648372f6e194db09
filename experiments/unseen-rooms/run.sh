#!/usr/bin/env bash
# Rooms never trained in (README.md). Days of CPU on 2 cores; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
NLOS=.venv/bin/nlos
HERE=experiments/unseen-rooms

for I in 0 1; do $NLOS generate benchmarks/configs/unseen-train.yaml --out out/unseen/train --shard "$I/2"; done
$NLOS generate benchmarks/configs/unseen-test.yaml --out out/unseen/test
$PY $HERE/unseen_rooms.py --train out/unseen/train --test out/unseen/test --rooms 200,100,50,25 \
    --nets geometry --ien --ien-features normals,adaptive --ien-prior-weight 1 --steps 2400 --threads 1 \
    --runs out/unseen/runs-s2400 --out docs/results/unseen-geometry
# the same with --nets image --rooms 200,100 (and 50,25); --rooms 200 --seeds 3 for both networks;
# --nets geometry --rooms 200 --captures noise-free
# (the notebook names no --out for these; docs/results/unseen-image and unseen-noisefree hold them)
$PY $HERE/unseen_rooms_table.py docs/results/unseen-*/unseen-rooms.csv out/unseen/collect-*/unseen-rooms.csv \
    --out docs/results/unseen-rooms
