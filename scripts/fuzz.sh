#!/usr/bin/env bash
# Runs one libFuzzer target for a bounded time on a scratch copy of its seed corpus, so the
# corpus in the repository only changes when someone copies a finding into it on purpose.
#   scripts/fuzz.sh BUILD/fuzz/<reader>_fuzz fuzz/corpus/<reader> SECONDS [LOG]
# Single process, niced; a crash, a sanitizer report, a leak, a hang over 10 s or more than
# 2 GB of memory fails the run (exit != 0) and leaves the input in fuzz/findings/<reader>/.
set -euo pipefail
target=$1 corpus=$2 seconds=$3 log=${4:-}
source_dir=$(cd "$(dirname "$0")/.." && pwd)
name=$(basename "$target" _fuzz)
work=$(mktemp -d "${TMPDIR:-/tmp}/locard-fuzz-$name.XXXXXX")
trap 'rm -rf "$work"' EXIT
cp -r "$corpus"/. "$work/"
findings="$source_dir/fuzz/findings/$name"
mkdir -p "$findings"
dict=()
if [[ -f "$source_dir/fuzz/dict/$name.dict" ]]; then dict=(-dict="$source_dir/fuzz/dict/$name.dict"); fi
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
run=(nice -n 19 "$target" "${dict[@]}" -max_total_time="$seconds" -timeout=10
     -rss_limit_mb=2048 -malloc_limit_mb=2048 -max_len=65536 -print_final_stats=1
     -artifact_prefix="$findings/" "$work")
if [[ -n "$log" ]]; then "${run[@]}" 2>&1 | tee "$log"; exit "${PIPESTATUS[0]}"; fi
exec "${run[@]}"
