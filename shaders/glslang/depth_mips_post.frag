#version 450
#extension GL_EXT_samplerless_texture_functions : require
// Post pass over the main depth's mip chain (built by `depth_downsample.frag`): the bottom
// quarter of the image is overwritten with a shade of the view distance read from mip level 1
// (the farthest of each 2 x 2 block), the top quarter with that of level 2 (each 4 x 4 block),
// texel fetches through a view of the whole chain in SHADER_READ_ONLY_OPTIMAL. The rest of
// the image is left as it is. Depth 1 (the cleared background) shades as the far plane. A
// level holding reversed values, or one whose read twin was not refreshed, shades its band
// wrong.

layout(set = 0, binding = 0) uniform texture2D scene_depth;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;

float view_distance(float depth) {
    return NEAR * FAR / (FAR - depth * (FAR - NEAR));
}

void main() {
    ivec2 size = textureSize(scene_depth, 0);
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float depth;
    if (gl_FragCoord.y >= 0.75 * float(size.y)) {
        depth = texelFetch(scene_depth, pixel / 2, 1).r;
    } else if (gl_FragCoord.y < 0.25 * float(size.y)) {
        depth = texelFetch(scene_depth, pixel / 4, 2).r;
    } else {
        discard;
    }
    float z = view_distance(depth);
    out_color = vec4(clamp((z - 2.0) / 10.0, 0.0, 1.0), clamp((z - 2.0) / 5.0, 0.0, 1.0),
                     clamp(z / FAR, 0.0, 1.0), 1.0);
}
