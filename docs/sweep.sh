#!/usr/bin/env bash
# Regenerates the accuracy-vs-time study of docs/accuracy.md §5: `ispm sweep` over every bundled
# scene at 160x120, into target/sweep/SCENE (resumable: a second run measures only what is
# missing), then copies the plots to docs/images/sweep-SCENE-*.svg. References are cached under
# $XDG_CACHE_HOME/ispm/references (or ~/.cache/ispm/references).
#
# The grid: photons × kernel radius scale × subsample (the main cloud), accumulated frames
# (progressive accumulation, the wall time to the mean) at the cheaper points, plain bilinear
# upsampling against joint, then one knob at a time around 40k photons (bounces, caustic share)
# and the CPU photon-gather baseline. docs/tools/presets.py derives the --quality presets from
# the CSVs (docs/accuracy.md §5.3).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
ispm=target/release/ispm
for scene in cornell-box caustic-ring glass-sphere diffuse-box thin-walls facing-mirrors glass-cube; do
  out=target/sweep/$scene
  common=(--out "$out" --size 160x120 --frames 3)
  "$ispm" sweep "$scene" "${common[@]}" --grid 'photons=10k,40k,160k;radius=1,2;subsample=1,2,4'
  "$ispm" sweep "$scene" "${common[@]}" --grid 'photons=10k;radius=1;subsample=1;accumulate=4,16'
  "$ispm" sweep "$scene" "${common[@]}" --grid 'photons=40k;radius=1;subsample=1;accumulate=4'
  "$ispm" sweep "$scene" "${common[@]}" \
    --grid 'photons=40k;radius=1;subsample=2,4;upsample=bilinear'
  "$ispm" sweep "$scene" "${common[@]}" --grid 'photons=40k;radius=1;subsample=1;bounces=1,4'
  "$ispm" sweep "$scene" "${common[@]}" \
    --grid 'photons=40k;radius=1;subsample=1;caustic-share=0,0.75'
  "$ispm" sweep "$scene" "${common[@]}" \
    --grid 'method=photon-gather;photons=10k,40k,160k;radius=1;subsample=1'
  for plot in pareto stages knobs; do
    cp "$out/$plot.svg" "docs/images/sweep-$scene-$plot.svg"
  done
  cp "$out/results.csv" "docs/images/sweep-$scene.csv"
done
# The presets come from the four scenes of ordinary content; the hard cases (thin-walls,
# facing-mirrors, glass-cube: docs/stability.md) are swept for the headline, not for them.
python3 docs/tools/presets.py docs/images/sweep-{cornell-box,caustic-ring,glass-sphere,diffuse-box}.csv
