#version 450
#extension GL_EXT_samplerless_texture_functions : require
// Post pass over a layered main depth image (a 2D array of two layers, each rendered through a
// view of that layer alone: the cascades of a shadow map, or two views): the bottom quarter of
// the image is overwritten with a shade of the view distance read from layer 0, the quarter
// above it (rows from 1/2 to 3/4 of the height) with that of layer 1, texel fetches through a
// 2D-array view of both layers in SHADER_READ_ONLY_OPTIMAL. The rest of the image is left as it
// is. Depth 1 (the cleared background) shades as the far plane. A layer holding reversed
// values, or one whose read twin was not refreshed, shades its band wrong.

layout(set = 0, binding = 0) uniform texture2DArray scene_depth;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;

float view_distance(float depth) {
    return NEAR * FAR / (FAR - depth * (FAR - NEAR));
}

void main() {
    ivec3 size = textureSize(scene_depth, 0);
    int layer;
    if (gl_FragCoord.y >= 0.75 * float(size.y)) {
        layer = 0;
    } else if (gl_FragCoord.y >= 0.5 * float(size.y)) {
        layer = 1;
    } else {
        discard;
    }
    float depth = texelFetch(scene_depth, ivec3(ivec2(gl_FragCoord.xy), layer), 0).r;
    float z = view_distance(depth);
    out_color = vec4(clamp((z - 2.0) / 10.0, 0.0, 1.0), clamp((z - 2.0) / 5.0, 0.0, 1.0),
                     clamp(z / FAR, 0.0, 1.0), 1.0);
}
