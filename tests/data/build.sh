#!/bin/sh
# Rebuilds the SPIR-V fixtures of the tests from the sources beside them, then
# records the SHA-256 of every source and output in SHA256SUMS (checked by
# tests/tests/committed_spirv.rs, which also runs this script into a temporary
# folder and compares when glslang is installed). Needs glslang-tools and
# spirv-tools (apt-get install -y glslang-tools spirv-tools).
#
#   tests/data/build.sh [OUT_DIR]   # OUT_DIR defaults to tests/data itself
#
# raygen_debug_info.rgen.spv is raygen_main.rgen with glslang's full debug info
# (-gVS: NonSemantic.Shader.DebugInfo.100 and the source text); it records the
# source path as given, so the script runs from this folder with relative paths.
set -eu
cd "$(dirname "$0")"
out=${1:-.}
mkdir -p "$out"
glsl() { glslangValidator --target-env vulkan1.2 "$@" >/dev/null; }
glsl -o "$out/compute_only.comp.spv" compute_only.comp
glsl -o "$out/miss_other_params.rmiss.spv" miss_other_params.rmiss
glsl -o "$out/payload_spec_array.rgen.spv" payload_spec_array.rgen
glsl -o "$out/raygen_main.rgen.spv" raygen_main.rgen
glsl -o "$out/storage_at_set_2.rgen.spv" storage_at_set_2.rgen
glsl -o "$out/image_at_set_0_binding_1.rgen.spv" image_at_set_0_binding_1.rgen
glsl -o "$out/tlas_at_set_0_binding_0.rgen.spv" tlas_at_set_0_binding_0.rgen
glsl -o "$out/raygen_calls_callable_2.rgen.spv" raygen_calls_callable_2.rgen
glsl -o "$out/callable_white.rcall.spv" callable_white.rcall
glsl -gVS -o "$out/raygen_debug_info.rgen.spv" raygen_main.rgen
glsl -e __miss__named_wrong --source-entrypoint main -o "$out/raygen_named_miss.rgen.spv" raygen_named_miss.rgen
spirv-as --target-env spv1.5 -o "$out/no_entry_points.spv" no_entry_points.spvasm
if [ "$out" = . ]; then
    sha256sum compute_only.comp miss_other_params.rmiss payload_spec_array.rgen raygen_main.rgen \
        storage_at_set_2.rgen image_at_set_0_binding_1.rgen tlas_at_set_0_binding_0.rgen raygen_named_miss.rgen no_entry_points.spvasm \
        raygen_calls_callable_2.rgen callable_white.rcall *.spv > SHA256SUMS
fi
