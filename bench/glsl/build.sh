#!/bin/sh
# The GLSL twin of the primary-ray programs (examples/triangle's Rust programs:
# one camera ray per pixel, barycentric colour, RGBA8 store), compiled with
# glslang and optimised with `spirv-opt -O`, as the benchmarks load them.
# Needs glslang-tools and spirv-tools. The path tracer's twin is built by
# examples/path_tracer/glsl/build.sh.
set -eu
cd "$(dirname "$0")"
src=../../examples/triangle/glsl
for s in rgen rmiss rchit; do
    glslangValidator --target-env vulkan1.2 -o "primary.$s.unopt.spv" "$src/triangle.$s" >/dev/null
    spirv-opt -O --scalar-block-layout "primary.$s.unopt.spv" -o "primary.$s.spv"
    rm "primary.$s.unopt.spv"
    spirv-val --target-env vulkan1.2 --scalar-block-layout "primary.$s.spv"
done
