#version 450
// Soft-particle fragment shader: the particle's flat color, faded where it comes close to the
// scene behind it. The scene's depth is read with a texel fetch from the main depth image,
// which the pass has attached read-only (depth test LESS, no writes) while it samples it; the
// fade is linear in view distance over FADE_DISTANCE. A standard depth d of the overlap camera
// (near 0.1, far 100) lies at view distance n f / (f - d (f - n)).

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(set = 0, binding = 0) uniform texture2D scene_depth;
layout(set = 0, binding = 1) uniform sampler nearest_sampler;

layout(location = 0) in float view_distance;
layout(location = 0) out vec4 out_color;

const float NEAR = 0.1;
const float FAR = 100.0;
const float FADE_DISTANCE = 0.6;

void main() {
    float depth = texelFetch(sampler2D(scene_depth, nearest_sampler), ivec2(gl_FragCoord.xy), 0).r;
    float scene_distance = NEAR * FAR / (FAR - depth * (FAR - NEAR));
    float fade = clamp((scene_distance - view_distance) / FADE_DISTANCE, 0.0, 1.0);
    out_color = vec4(pc.color.rgb * (0.25 + 0.75 * fade), pc.color.a);
}
