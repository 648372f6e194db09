#!/usr/bin/env bash
# Physics first: backprojection and FloorNet across rooms (README.md). Hours on 2 cores; not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
HERE=experiments/backprojection-across-rooms
IEN_PT=out/unseen/runs-s2400/ien-normals-adaptive-prior1-2000steps/ien.pt   # experiments/unseen-rooms' IEN

$PY $HERE/backprojection_unseen.py --train out/unseen/train --test out/unseen/test --rooms 40 \
    --out docs/results/backprojection-unseen.csv
for S in 0 1 2; do
    $PY $HERE/backprojection_net.py --train out/unseen/train --test out/unseen/test --rooms 200 --steps 3000 \
        --templates 2 --seed "$S" --ien "$IEN_PT" --out "out/backprojection-net/t2-s$S"
done
# also --templates 1; --capture spot (the notebook names no --out for these)
$PY $HERE/backprojection_table.py out/backprojection-net/* --out docs/results/backprojection-net
$PY $HERE/backprojection_seen.py --data out/lc/data --run out/backprojection-net/t2-s0 \
    --out docs/results/backprojection-seen.csv
$PY $HERE/backprojection_seen.py --data out/lc/data --run out/backprojection-net/t2-s0 \
    --finetune 1500 --out docs/results/backprojection-seen-finetune1500.csv
$PY $HERE/floor_net_decimation.py --test out/unseen/test --ien "$IEN_PT" \
    --runs out/backprojection-net/t2-s0 out/backprojection-net/t2-s1 out/backprojection-net/t2-s2 \
    --out docs/results/unseen-paper/fig7-decimation.csv

# the IEN on FloorNet's task loss: task tables in two shards, then the objectives
for I in 0 1; do
    $PY $HERE/ien_task_across_rooms.py --train out/unseen/train --test out/unseen/test \
        --floor-net out/backprojection-net/t2-s0 --bound --shard "$I/2"
done
$PY $HERE/ien_task_across_rooms.py --train out/unseen/train --test out/unseen/test \
    --floor-net out/backprojection-net/t2-s0 --score-nets out/backprojection-net/t2-s1 --seeds 2 \
    --objectives snr,task --out docs/results/ien-task-across-rooms/snr-task.csv
$PY $HERE/ien_task_across_rooms.py --train out/unseen/train --test out/unseen/test \
    --floor-net out/backprojection-net/t2-s0 --score-nets out/backprojection-net/t2-s1 --seeds 2 \
    --objectives task+snr,task-ce --policies oracle --out docs/results/ien-task-across-rooms/task-snr-ce.csv
$PY $HERE/ien_task_across_rooms.py --train out/unseen/train --test out/unseen/test \
    --floor-net out/backprojection-net/t2-s0 --seeds 2 \
    --objectives task-ce --policies oracle --table-people 4 --out docs/results/ien-task-across-rooms/task-ce-4people.csv
$PY $HERE/ien_task_across_rooms.py --train out/unseen/train --test out/unseen/test \
    --floor-net out/backprojection-net/t2-s0 --objectives "" --policies oracle --bound \
    --out docs/results/ien-task-across-rooms/bound.csv
