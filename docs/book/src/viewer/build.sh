#!/bin/sh
# Rebuilds cornell-box.png, the viewer's picture of the Cornell box shown in the
# book's viewer chapter: the window at 480x360 after an orbit (`drag 70 -25`) and
# 16 frames of 8 paths per pixel, on lavapipe. It is rendered with `--headless`
# from the camera the window printed, which gives the window's bytes exactly (the
# viewer's tests check that bit for bit); then SHA256SUMS records it.
#
#   docs/book/src/viewer/build.sh   # from anywhere; needs the shaders (cargo xtask build-shaders)
set -eu
cd "$(dirname "$0")/../../../.."
cargo run --release --quiet -p path_tracer -- --headless --width 480 --height 360 --frames 16 \
    --spp-per-frame 8 --camera 696.4735,426.3499,-816.41345,278,273,330,0,1,0,35 -o docs/book/src/viewer/cornell-box.png
rm -f docs/book/src/viewer/cornell-box.exr
cd docs/book/src/viewer
sha256sum cornell-box.png > SHA256SUMS
