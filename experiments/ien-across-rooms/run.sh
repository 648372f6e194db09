#!/usr/bin/env bash
# The IEN across rooms (README.md). Needs out/unseen/train and out/unseen/test; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python

$PY experiments/ien-across-rooms/ien_across_rooms.py --data out/unseen/train --test out/unseen/test \
    --train-rooms 200 --eval-rooms 40 --features "normals;normals,adaptive" --prior-weight 1 --seeds 2 --steps 2000
