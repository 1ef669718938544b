#!/usr/bin/env bash
# Runs every benchmark program; each prints Locard's figures beside its peers' from this run.
set -euo pipefail
build=${1:-build/release}
for b in "$build"/bench/*_bench; do
  echo "== $(basename "$b")"
  "$b" --benchmark_min_time=1
  echo
done
