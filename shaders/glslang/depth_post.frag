#version 450
// Post pass over the main depth (SSAO, fog and depth-of-field passes read depth this way):
// the bottom quarter of the image is overwritten with a shade of the scene's view distance,
// read three ways side by side: a texel fetch (left third), a bilinear sample a quarter texel
// off the pixel's centre, which mixes four texels where the device filters the depth format
// linearly (nearest where it does not, as lavapipe 22.3) (middle third), and a gather of the four
// texels around the pixel, averaged (right third). The rest of the image is left as it is.
// Depth 1 (the cleared background) shades as the far plane. A reversed value would shade the
// whole band wrong.

layout(set = 0, binding = 0) uniform texture2D scene_depth;
layout(set = 0, binding = 1) uniform sampler nearest_sampler;
layout(set = 0, binding = 2) uniform sampler linear_sampler;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;

float view_distance(float depth) {
    return NEAR * FAR / (FAR - depth * (FAR - NEAR));
}

void main() {
    ivec2 size = textureSize(sampler2D(scene_depth, nearest_sampler), 0);
    if (gl_FragCoord.y < 0.75 * float(size.y)) {
        discard;
    }
    vec2 uv = gl_FragCoord.xy / vec2(size);
    float depth;
    if (gl_FragCoord.x < float(size.x) / 3.0) {
        depth = texelFetch(sampler2D(scene_depth, nearest_sampler), ivec2(gl_FragCoord.xy), 0).r;
    } else if (gl_FragCoord.x < 2.0 * float(size.x) / 3.0) {
        depth = texture(sampler2D(scene_depth, linear_sampler), uv + 0.25 / vec2(size)).r;
    } else {
        vec4 quad = textureGather(sampler2D(scene_depth, nearest_sampler), uv + 0.5 / vec2(size), 0);
        depth = 0.25 * (quad.x + quad.y + quad.z + quad.w);
    }
    float z = view_distance(depth);
    out_color = vec4(clamp((z - 2.0) / 10.0, 0.0, 1.0), clamp((z - 2.0) / 5.0, 0.0, 1.0),
                     clamp(z / FAR, 0.0, 1.0), 1.0);
}
