#version 450
// Shadow-receiver fragment shader: the object's flat color, darkened where the shadow map
// (standard depth, cleared to 1.0, written with LESS) holds something nearer to the light.
// The comparison sampler uses LESS_OR_EQUAL: lit = (reference <= stored).

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(set = 0, binding = 1) uniform texture2D shadow_map;
layout(set = 0, binding = 2) uniform samplerShadow shadow_sampler;

layout(location = 0) in vec4 light_clip;
layout(location = 0) out vec4 out_color;

// Light-space depth offset that keeps a lit surface from shadowing itself (the shadow pass
// also uses a rasterization depth bias).
const float SHADOW_BIAS = 0.004;

void main() {
    vec3 ndc = light_clip.xyz / light_clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    float lit = texture(sampler2DShadow(shadow_map, shadow_sampler), vec3(uv, ndc.z - SHADOW_BIAS));
    out_color = vec4(pc.color.rgb * (0.45 + 0.55 * lit), pc.color.a);
}
