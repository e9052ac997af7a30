#!/usr/bin/env bash
# Regenerates the committed seed modules of the fuzz targets (layer/src/fuzz/) from src/ and
# ../../shaders/ with glslang (Debian: glslang-tools) and spirv-opt (spirv-tools). CI does not
# run this: the .spv files are committed. The fuzz targets also compile ../../shaders/ with
# naga at test time.
set -euo pipefail
cd "$(dirname "$0")"
g=glslangValidator
$g -V -o scene.vert.spv ../../shaders/scene.vert >/dev/null
$g -V -o mvp_pair.vert.spv ../../shaders/mvp_pair.vert >/dev/null
$g -V -g -o camera_debug.vert.spv src/camera.vert >/dev/null
spirv-opt -O camera_debug.vert.spv -o camera_opt.vert.spv
$g -V -o uniform.vert.spv src/uniform.vert >/dev/null
$g -V -o draw_parameters.vert.spv src/draw_parameters.vert >/dev/null
$g -V -D -S vert -e main -o row_major.vert.spv src/row_major.hlsl >/dev/null
$g -V -D -S vert -e main -o row_vector.vert.spv src/row_vector.hlsl >/dev/null
$g -V -o frag_depth.frag.spv ../../shaders/frag_depth.frag >/dev/null
$g -V -o fog.frag.spv src/fog.frag >/dev/null
spirv-opt -O fog.frag.spv -o fog_opt.frag.spv
$g -V -g -o decal_debug.frag.spv src/decal.frag >/dev/null
$g -V -D -S frag -e main -o impostor.frag.spv src/impostor.hlsl >/dev/null
for f in *.spv; do spirv-val --target-env vulkan1.1 "$f"; done
