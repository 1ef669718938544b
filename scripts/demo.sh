#!/usr/bin/env bash
# The main job on the built-in demo scene: simulate the paper's bedroom scan with a Kinect v2,
# inspect it, and merge it into one coloured cloud at the ground-truth poses.
# Later stages (alignment, meshing, the case report) extend this script.
set -euo pipefail
locard=${1:-build/release/locard}
out=${2:-out/demo}
mkdir -p "$out"

echo "== 1. simulated Kinect v2 scan of the bedroom (exact ground truth)"
"$locard" scan-sim -o "$out/scan" --force
echo
echo "== 2. what the scan holds"
"$locard" info "$out/scan"
echo
echo "== 3. all views back-projected at their ground-truth poses"
"$locard" convert "$out/scan" "$out/bedroom-ground-truth-cloud.ply" --stride 2 --force
echo
echo "demo outputs in $out/ (open the .ply files in CloudCompare, MeshLab or Blender)"
