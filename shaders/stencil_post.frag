#version 450
// Post pass over the main depth-stencil image: a band across the middle of the image (from
// 45% to 70% of its height, over the cubes, the ground and the background) is overwritten
// with a shade of the stencil value (a texel fetch of its stencil aspect) and of the depth's
// view distance (a texel fetch of its depth aspect); the rest is left as it is. The stencil
// marks which surface covers each pixel, so a twin whose stencil was not kept, or whose depth
// a stencil copy overwrote, shades the band wrong.

layout(set = 0, binding = 0) uniform texture2D scene_depth;
layout(set = 0, binding = 1) uniform sampler nearest_sampler;
layout(set = 0, binding = 3) uniform utexture2D scene_stencil;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;

void main() {
    ivec2 size = textureSize(sampler2D(scene_depth, nearest_sampler), 0);
    if (gl_FragCoord.y < 0.45 * float(size.y) || gl_FragCoord.y >= 0.7 * float(size.y)) {
        discard;
    }
    ivec2 texel = ivec2(gl_FragCoord.xy);
    float depth = texelFetch(sampler2D(scene_depth, nearest_sampler), texel, 0).r;
    uint stencil = texelFetch(usampler2D(scene_stencil, nearest_sampler), texel, 0).r;
    float z = NEAR * FAR / (FAR - depth * (FAR - NEAR));
    out_color = vec4(0.4 * float(stencil), clamp((z - 2.0) / 10.0, 0.0, 1.0),
                     stencil == 0u ? 1.0 : 0.0, 1.0);
}
