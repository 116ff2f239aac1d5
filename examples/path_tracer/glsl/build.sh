#!/bin/sh
# Rebuilds the committed .spv files of the GLSL twin: glslang, then spirv-opt -O,
# checked with spirv-val; then records the SHA-256 of every source and output in
# SHA256SUMS (checked by tests/tests/committed_spirv.rs).
# Needs glslang-tools and spirv-tools (apt-get install -y glslang-tools spirv-tools).
#
#   examples/path_tracer/glsl/build.sh [OUT_DIR]   # OUT_DIR defaults to this folder
set -eu
cd "$(dirname "$0")"
out=${1:-.}
mkdir -p "$out"
for s in path_tracer.rgen path_tracer.rmiss shadow.rmiss path_tracer.rchit shadow.rchit; do
    glslangValidator --target-env vulkan1.2 -o "$out/$s.unopt.spv" "$s" >/dev/null
    spirv-opt -O --scalar-block-layout "$out/$s.unopt.spv" -o "$out/$s.spv"
    rm "$out/$s.unopt.spv"
    spirv-val --target-env vulkan1.2 --scalar-block-layout "$out/$s.spv"
done
if [ "$out" = . ]; then
    sha256sum common.glsl path_tracer.rgen path_tracer.rmiss shadow.rmiss path_tracer.rchit shadow.rchit *.spv \
        > SHA256SUMS
fi
