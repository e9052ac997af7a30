#version 450
// Shadow-receiver fragment shader reading the shadow map's raw depth values: the object's flat
// color, darkened by the fraction of map values nearer to the light than the fragment, read
// with a texel fetch and a sample through a plain (non-comparison, nearest) sampler, and
// compared here (lit = reference <= stored, the comparison sampler's LESS_OR_EQUAL). A map that
// handed over reversed values would shadow nearly everything. (naga's GLSL front end has no
// `textureGather`: the four texels of a gather are fetched instead.)

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(set = 0, binding = 1) uniform texture2D shadow_map;
layout(set = 0, binding = 3) uniform sampler plain_sampler;

layout(location = 0) in vec4 light_clip;
layout(location = 0) out vec4 out_color;

// As `shadow_receiver.frag`.
const float SHADOW_BIAS = 0.004;

void main() {
    vec3 ndc = light_clip.xyz / light_clip.w;
    vec2 uv = ndc.xy * 0.5 + 0.5;
    float reference = ndc.z - SHADOW_BIAS;
    ivec2 size = textureSize(sampler2D(shadow_map, plain_sampler), 0);
    ivec2 texel = clamp(ivec2(uv * vec2(size)), ivec2(0), size - 1);
    float sampled = texture(sampler2D(shadow_map, plain_sampler), uv).r;
    ivec2 next = min(texel + 1, size - 1);
    vec4 quad = vec4(
        texelFetch(sampler2D(shadow_map, plain_sampler), texel, 0).r,
        texelFetch(sampler2D(shadow_map, plain_sampler), ivec2(next.x, texel.y), 0).r,
        texelFetch(sampler2D(shadow_map, plain_sampler), ivec2(texel.x, next.y), 0).r,
        texelFetch(sampler2D(shadow_map, plain_sampler), next, 0).r);
    vec4 lit4 = step(vec4(reference), quad);
    float lit = 0.5 * step(reference, sampled) + 0.125 * (lit4.x + lit4.y + lit4.z + lit4.w);
    out_color = vec4(pc.color.rgb * (0.45 + 0.55 * lit), pc.color.a);
}
