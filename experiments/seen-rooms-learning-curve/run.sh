#!/usr/bin/env bash
# Seen rooms: the learning curve and the ablation (README.md). Many core-hours; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
NLOS=.venv/bin/nlos
HERE=experiments/seen-rooms-learning-curve

for I in 0 1 2; do $NLOS generate benchmarks/configs/learning-curve.yaml --out out/lc/data --shard "$I/3"; done
$PY $HERE/learning_curve.py --data out/lc/data --sizes 100,300,1000,3000 --epochs 10 --min-steps 800 \
    --patience 0 --burst 16
$PY $HERE/learning_curve.py --data out/lc/data --sizes 100,300,1000,3000 --epochs 10 --min-steps 800 \
    --patience 0 --other-networks-only --resnet18 --baselines chandran --other-networks-size 1000
# the CRB column: the bound is the physics-bounds study's; it reads these runs' spots
$PY experiments/physics-bounds/position_crb.py --data out/lc/data --people 8
$PY $HERE/learning_curve.py --data out/lc/data --sizes 100,300,1000,3000 --epochs 10 --min-steps 800 \
    --patience 0 --burst 16 --crb docs/results/position-crb.json   # all runs reused
for N in 4 8; do
    $PY $HERE/learning_curve.py --data out/lc/data --sizes 3000 --policies "" --epochs 10 --min-steps 800 \
        --patience 0 --burst "$N" --out "out/lc-burst$N"
done
$PY $HERE/learning_curve.py --data out/lc/data --sizes 3000 --policies center,random,adaptive,ien --burst 16 \
    --policies-burst --per-room --epochs 60 --patience 0 --out docs/results/per-room --crb docs/results/position-crb.json
$PY $HERE/learning_curve.py --data out/lc/data --sizes 3000 --policies "" --per-room --select metrics \
    --only noise-free --epochs 60 --patience 0 --threads 1 --out docs/results/per-room-select

# the ablation: flags from docs/results/learning-ablation.csv's columns (the notebook elides them)
$PY $HERE/learning_ablation.py --data out/lc/data --rooms 1 --n 300 --min-steps 600 --capture noise-free \
    --variants baseline,cifar-stem,norm-background,chandran,coord
$PY $HERE/learning_ablation.py --data out/lc/data --rooms 2 --n 500 --min-steps 800 --capture noise-free \
    --variants baseline,mixed-batches,per-room,mixed-batches+spatial,mixed-batches+chandran,mixed-batches+half-stem
