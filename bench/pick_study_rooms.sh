#!/usr/bin/env bash
# Issue 15's pick study over generated rooms: for each seed, `locard scan-sim --random SEED`,
# `locard reconstruct`, then bench/pick_study.py on a copy of the case (every reference distance
# with both ends moved 1.5 cm along the surface, both ways). Prints each room's line and the
# share within U over all rooms; the rooms' work folders stay under WORK, each with ends.json
# (every end's feature and offset: `bench/pick_ends.py WORK/room-*/ends.json`).
#   bench/pick_study_rooms.sh LOCARD WORK SEED [SEED...]
set -uo pipefail
locard=$(realpath "$1"); work=$2; shift 2
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$work"
within=0; total=0; beyond=0; off=0
for seed in "$@"; do
  room=$work/room-$seed
  rm -rf "$room"; mkdir -p "$room"
  "$locard" scan-sim --random "$seed" -o "$room/scan" > "$room/scan-sim.log" 2>&1 || { echo "seed $seed: scan-sim failed"; continue; }
  "$locard" reconstruct "$room/scan" -o "$room/case" --no-pdf > "$room/reconstruct.log" 2>&1
  rc=$?
  [ -f "$room/case/mesh/mesh.ply" ] || { echo "seed $seed: no mesh (reconstruct exit $rc)"; continue; }
  cp -r "$room/case" "$room/case-picks"
  /usr/bin/python3 "$here/pick_study.py" "$room/scan" "$room/case-picks" "$locard" --ends "$room/ends.json" > "$room/picks.log" 2>&1
  line=$(tail -n 1 "$room/picks.log")
  echo "seed $seed (reconstruct exit $rc): $line"
  if [[ $line =~ within\ U\ \(both\ ends\ snapped\):\ ([0-9]+)/([0-9]+)\;\ beyond\ 3U:\ ([0-9]+) ]]; then
    within=$((within + BASH_REMATCH[1])); total=$((total + BASH_REMATCH[2])); beyond=$((beyond + BASH_REMATCH[3]))
  fi
  [[ $line =~ off\ the\ model:\ ([0-9]+) ]] && off=$((off + BASH_REMATCH[1]))
done
echo "all rooms: within U (both ends snapped) $within/$total; beyond 3U $beyond/$total; tape end off the model $off/$total"
