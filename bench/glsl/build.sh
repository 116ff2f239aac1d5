#!/bin/sh
# The GLSL twin of the primary-ray programs (examples/triangle's Rust programs:
# one camera ray per pixel, barycentric colour, RGBA8 store), compiled with
# glslang and optimised with `spirv-opt -O`, as the benchmarks load them; then
# the SHA-256 of every source and output recorded in SHA256SUMS (checked by
# tests/tests/committed_spirv.rs). The twin's sources are examples/triangle/glsl's.
#
# The independent ash baseline's programs (independent.*: the same picture with a
# plain descriptor set and the camera in push constants, see
# bench/src/ash_independent.rs) are built the same way from this folder.
#
# Needs glslang-tools and spirv-tools. The path tracer's twin is built by
# examples/path_tracer/glsl/build.sh.
#
#   bench/glsl/build.sh [OUT_DIR]   # OUT_DIR defaults to this folder
set -eu
cd "$(dirname "$0")"
out=${1:-.}
mkdir -p "$out"
src=../../examples/triangle/glsl
# compile SOURCE OUTPUT: glslang, `spirv-opt -O`, `spirv-val`.
compile() {
    glslangValidator --target-env vulkan1.2 -o "$2.unopt.spv" "$1" >/dev/null
    spirv-opt -O --scalar-block-layout "$2.unopt.spv" -o "$2"
    rm "$2.unopt.spv"
    spirv-val --target-env vulkan1.2 --scalar-block-layout "$2"
}
for s in rgen rmiss rchit; do
    compile "$src/triangle.$s" "$out/primary.$s.spv"
    compile "independent.$s" "$out/independent.$s.spv"
done
if [ "$out" = . ]; then
    sha256sum "$src/common.glsl" "$src/triangle.rgen" "$src/triangle.rmiss" "$src/triangle.rchit" \
        independent.glsl independent.rgen independent.rmiss independent.rchit primary.*.spv independent.*.spv \
        > SHA256SUMS
fi
