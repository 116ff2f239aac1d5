#!/bin/sh
# Rebuilds the committed .spv files of the triangle's GLSL twin with glslang (no
# spirv-opt: the tests load them as glslang writes them), then records the SHA-256
# of every source and output in SHA256SUMS (checked by
# tests/tests/committed_spirv.rs). Needs glslang-tools.
#
#   examples/triangle/glsl/build.sh [OUT_DIR]   # OUT_DIR defaults to this folder
set -eu
cd "$(dirname "$0")"
out=${1:-.}
mkdir -p "$out"
for s in rgen rmiss rchit; do
    glslangValidator --target-env vulkan1.2 -o "$out/triangle.$s.spv" "triangle.$s" >/dev/null
done
if [ "$out" = . ]; then
    sha256sum common.glsl triangle.rgen triangle.rmiss triangle.rchit triangle.*.spv > SHA256SUMS
fi
