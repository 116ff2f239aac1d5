#!/bin/sh
# Builds the OptiX twin of raykit-bench's `primary` and `path` suites:
#   OPTIX_INCLUDE=/path/to/optix-dev/include bench/optix/build.sh [OUT_DIR]
# OUT_DIR (default bench/optix/build) receives raykit-optix (the host program)
# and primary.optixir, path.optixir (the device programs; .ptx where this nvcc
# cannot write OptiX IR). Needs CUDA's nvcc; at run time the NVIDIA driver's
# libnvoptix. NVCC, OPTIX_ARCH (default sm_90) and NVCC_FLAGS override the
# compiler, the device code's target and extra flags; OPTIX_FAST_MATH=0 leaves
# out --use_fast_math (which the device programs get by default, as the OptiX
# SDK's samples do).
set -eu

here=$(cd "$(dirname "$0")" && pwd)
out=${1:-$here/build}
nvcc=${NVCC:-nvcc}
arch=${OPTIX_ARCH:-sm_90}
fast_math=--use_fast_math
[ "${OPTIX_FAST_MATH:-1}" = 0 ] && fast_math=

# Leaves the reason in OUT_DIR/NOT_BUILT, which raykit-bench's `optix` suite
# reports, and stops.
not_built() {
    mkdir -p "$out"
    printf '%s\n' "$1" >"$out/NOT_BUILT"
    echo "build.sh: $1" >&2
    exit 2
}

rm -f "$out/NOT_BUILT"
if [ -z "${OPTIX_INCLUDE:-}" ]; then
    cat >&2 <<'MSG'
build.sh: OPTIX_INCLUDE is not set. The OptiX headers are not in this
repository (NVIDIA's licence allows no redistribution). Get OptiX 9.0's headers
(github.com/NVIDIA/optix-dev, tag v9.0.0, folder include/, or the OptiX SDK's
include/) and point OPTIX_INCLUDE at that folder, e.g.
    git clone --depth 1 --branch v9.0.0 https://github.com/NVIDIA/optix-dev .optix
    OPTIX_INCLUDE=$PWD/.optix/include bench/optix/build.sh
MSG
    not_built "OPTIX_INCLUDE was not set when bench/optix/build.sh ran (the OptiX 9.0 headers)"
fi
if [ ! -f "$OPTIX_INCLUDE/optix.h" ]; then
    not_built "no optix.h in OPTIX_INCLUDE=$OPTIX_INCLUDE"
fi
if ! command -v "$nvcc" >/dev/null 2>&1; then
    not_built "$nvcc (CUDA's compiler) was not found; set NVCC"
fi

mkdir -p "$out"
# shellcheck disable=SC2086
"$nvcc" -std=c++17 -O2 -I"$OPTIX_INCLUDE" -I"$here" ${NVCC_FLAGS:-} "$here/main.cpp" -o "$out/raykit-optix" -ldl
for program in primary path; do
    rm -f "$out/$program.optixir" "$out/$program.ptx"
    # As the OptiX SDK's samples: fast math, relocatable device code.
    # shellcheck disable=SC2086
    if ! "$nvcc" -optix-ir -arch="$arch" -std=c++17 $fast_math -rdc=true -I"$OPTIX_INCLUDE" -I"$here" \
        ${NVCC_FLAGS:-} "$here/$program.cu" -o "$out/$program.optixir"; then
        echo "build.sh: no OptiX IR from $nvcc; compiling $program.cu to PTX" >&2
        # shellcheck disable=SC2086
        "$nvcc" -ptx -arch="$arch" -std=c++17 $fast_math -rdc=true -I"$OPTIX_INCLUDE" -I"$here" \
            ${NVCC_FLAGS:-} "$here/$program.cu" -o "$out/$program.ptx"
    fi
done
echo "build.sh: built $out/raykit-optix and its device programs"
