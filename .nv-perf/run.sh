#!/bin/bash
# Path-tracer variants (see the perf report): runs from the repo root as
# `bash .nv-perf/run.sh`; each variant is a folder of .spv (all device crates).
set -u
D=.nv-perf
for v in spirv-baseline spirv-perf spirv-perf-opt spirv-perf-unchecked; do
    echo "== $v"
    mkdir -p "$OUT/$v"
    "$D/raykit-bench" path --reps 10 --spirv-dir "$D/$v" --out "$OUT/$v" || echo "FAILED: $v"
done
