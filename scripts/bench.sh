#!/usr/bin/env bash
# Runs every benchmark program; each prints Locard's figures beside its peers' from the same
# run, through the peer harness (bench/harness: same inputs, parameters, warm-up, repeats and
# threads on every side). Extra arguments go to every program, e.g. --repeats=5.
# PCL is measured where its peers are built: configure a build with -DLOCARD_WITH_PCL=ON, or
# point LOCARD_PCL_PEER_DIR at a folder holding locard_pcl_peer and locard_pcl_registration.
set -euo pipefail
build=${1:-build/release}
shift || true
for b in "$build"/bench/*_bench; do
  echo "== $(basename "$b")"
  "$b" "$@"
  echo
done
