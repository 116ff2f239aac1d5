#!/bin/sh
# The GLSL twin of the primary-ray programs (examples/triangle's Rust programs:
# one camera ray per pixel, barycentric colour, RGBA8 store), compiled with
# glslang and optimised with `spirv-opt -O`, as the benchmarks load them; then
# the SHA-256 of every source and output recorded in SHA256SUMS (checked by
# tests/tests/committed_spirv.rs). The sources are examples/triangle/glsl's.
# Needs glslang-tools and spirv-tools. The path tracer's twin is built by
# examples/path_tracer/glsl/build.sh.
#
#   bench/glsl/build.sh [OUT_DIR]   # OUT_DIR defaults to this folder
set -eu
cd "$(dirname "$0")"
out=${1:-.}
mkdir -p "$out"
src=../../examples/triangle/glsl
for s in rgen rmiss rchit; do
    glslangValidator --target-env vulkan1.2 -o "$out/primary.$s.unopt.spv" "$src/triangle.$s" >/dev/null
    spirv-opt -O --scalar-block-layout "$out/primary.$s.unopt.spv" -o "$out/primary.$s.spv"
    rm "$out/primary.$s.unopt.spv"
    spirv-val --target-env vulkan1.2 --scalar-block-layout "$out/primary.$s.spv"
done
if [ "$out" = . ]; then
    sha256sum "$src/common.glsl" "$src/triangle.rgen" "$src/triangle.rmiss" "$src/triangle.rchit" primary.*.spv \
        > SHA256SUMS
fi
