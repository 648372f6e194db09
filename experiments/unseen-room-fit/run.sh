#!/usr/bin/env bash
# Rooms fitted by simulation in their own scan, and the studies on those fits (README.md).
# Days of CPU on 2 cores (each room's fit is resumable); not run by CI.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
PY=.venv/bin/python
HERE=experiments/unseen-room-fit
FITS=out/unseen/room-fit-3000

# the product's own fit in the first four test rooms (session 17; demo preset)
$PY $HERE/nlos_fit_rooms.py --test out/unseen/test --rooms 0-3 --preset demo --out out/unseen/nlos-fit-demo

$PY $HERE/unseen_room_fit.py --test out/unseen/test --rooms 10 --people 1200 --out out/unseen/room-fit
# the first ten rooms (docs/results.md), and 10-11, which the transfer and the synthesis use
for I in 0 1 2 3 4 5 6 7 8 9 10 11; do
    $PY $HERE/unseen_room_fit.py --test out/unseen/test --first "$I" --rooms 1 --people 3000 \
        --variants 16+e120 16+e120+x2 --out $FITS --threads 1
done
$PY $HERE/unseen_room_fit.py --test out/unseen/test --out $FITS --summary-only \
    --also docs/results/unseen-room-fit/room-fit.csv --pair 16+e120 16+e120+x2 --first 0 --rooms 10

# every method fitted in its room, with the rooms' own light and in the dark: rooms 0-3
for I in 0 1 2 3; do
    $PY $HERE/unseen_room_fit.py --test out/unseen/test --first "$I" --rooms 1 --people 3000 \
        --variants 16+e120+adaptive 16+e120+chandran 16+e120+adaptive+chandran 16+e120+ambient+dlnlos \
        16+e120+flash+tancik 16+e120+ambient 16+e120+dlnlos --out $FITS --threads 1
    $PY $HERE/unseen_room_fit.py --test out/unseen/test --first "$I" --rooms 1 --people 3000 \
        --variants 16+e120+lux0 16+e120+ambient+lux0.01 16+e120+adaptive+lux0 16+e120+ambient+lux0.1 \
        16+e120+adaptive+chandran+lux0 16+e120+chandran+lux0 16+e120+flash+lux0 16+e120+lux0+s1 \
        16+e120+adaptive+lux0+s1 --out $FITS --threads 1
done

# short of people or of fitting; which weights to keep
$PY $HERE/room_fit_gap.py --fits $FITS --rooms test-00000 test-00001 test-00002 test-00003 test-00004 \
    --variants 16 16+e120 --out docs/results/unseen-room-fit-3000/gap.csv
$PY $HERE/room_fit_weights.py --fits $FITS --test out/unseen/test --variants 16+e120 16+e120+x2 \
    --out docs/results/unseen-room-fit-3000/weights.csv

# people or rooms: two folds
$PY $HERE/fitted_rooms_transfer.py --fits $FITS --test out/unseen/test --train-rooms 0-5 --eval-rooms 6-11 \
    --renders 2 --epochs 30 --out out/unseen/transfer/a
$PY $HERE/fitted_rooms_transfer.py --fits $FITS --test out/unseen/test --train-rooms 6-11 --eval-rooms 0-5 \
    --renders 2 --epochs 30 --out out/unseen/transfer/b

# posture by synthesis, no training
$PY $HERE/synthesis_posture.py --test out/unseen/test --rooms 0-11 --know body place \
    --fit-runs $FITS --out out/unseen/synthesis
$PY $HERE/synthesis_posture.py --test out/unseen/test --rooms 0-11 --know position none \
    --people 15 --fit-runs $FITS --out out/unseen/synthesis
$PY $HERE/synthesis_posture.py --test out/unseen/test --summary-only --people 15 \
    --fit-runs $FITS --out out/unseen/synthesis

# the spot chosen by the task, in the dark, and a spot of low SNR (notebook, those sections); the +s1 seeds
# of the other spots are in the notebook's "Eight dark rooms" and "The spot chosen by the task, in the dark"
for I in 0 1 2 3; do
    $PY $HERE/unseen_room_fit.py --test out/unseen/test --first "$I" --rooms 1 --people 3000 \
        --variants 16+e120+lux0 16+e120+rank2+lux0 16+e120+adaptive+lux0 16+e120+rank3+lux0 16+e120+rank4+lux0 \
        --out $FITS --threads 1
done
$PY $HERE/unseen_room_fit.py --test out/unseen/test --out $FITS --summary-only \
    --task-spot 16+e120+lux0 16+e120+rank2+lux0 16+e120+rank3+lux0 16+e120+rank4+lux0 16+e120+adaptive+lux0
for I in 0 1 2 3 4; do
    $PY $HERE/unseen_room_fit.py --test out/unseen/test --first "$I" --rooms 1 --people 3000 \
        --variants 16+e120+center+lux0 --out $FITS --threads 1
done
for I in 2 3; do
    $PY $HERE/unseen_room_fit.py --test out/unseen/test --first "$I" --rooms 1 --people 3000 \
        --variants 16+e120+center+lux0+s1 --out $FITS --threads 1
done
$PY $HERE/spot_snr_posture.py --test out/unseen/test --fits $FITS --base 16+e120+lux0 \
    --others 16+e120+adaptive+lux0,16+e120+adaptive+lux0+s1 16+e120+rank2+lux0,16+e120+rank2+lux0+s1 \
    16+e120+rank3+lux0,16+e120+rank3+lux0+s1 16+e120+rank4+lux0 16+e120+center+lux0,16+e120+center+lux0+s1 \
    16+e120+center+lux0 \
    --out docs/results/unseen-room-fit-3000/spot-snr-posture.csv > docs/results/unseen-room-fit-3000/spot-snr-posture.txt
