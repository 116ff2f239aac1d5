#!/bin/sh
# Rebuilds the committed .spv files of the GLSL twin: glslang, then spirv-opt -O.
# Needs glslang-tools and spirv-tools (apt-get install -y glslang-tools spirv-tools).
set -eu
cd "$(dirname "$0")"
for s in path_tracer.rgen path_tracer.rmiss shadow.rmiss path_tracer.rchit shadow.rchit; do
    glslangValidator --target-env vulkan1.2 -o "$s.unopt.spv" "$s" >/dev/null
    spirv-opt -O --scalar-block-layout "$s.unopt.spv" -o "$s.spv"
    rm "$s.unopt.spv"
    spirv-val --target-env vulkan1.2 --scalar-block-layout "$s.spv"
done
