#version 450
// revz's conversion of a multisampled depth image into its read twin (issue #39), per
// sample: the twin (R32_SFLOAT, as many samples) receives scale * d + offset for every sample
// d of the depth aspect, clamped to [0, 1] unless `unclamped`. Dispatched per 8 x 8 texels
// and one layer (z) from `base_layer` on. The map is read from the first 16 bytes of revz's
// scratch buffer (set 0, the layout of the copy conversion), written by vkCmdUpdateBuffer.
// Compiled with `glslangValidator -V --target-env vulkan1.0 -o depth_convert_ms.comp.spv
// depth_convert_ms.comp`; the layer embeds the .spv (a test checks it is current).
#extension GL_EXT_samplerless_texture_functions : require
layout(local_size_x = 8, local_size_y = 8) in;

// (scale, offset, unclamped, base_layer), the floats as their bits: one load of four words,
// since lavapipe reads a storage buffer one invocation at a time, at a cost per access (four
// loads of one word each made the refresh about 1.7x as long there, session 25).
layout(set = 0, binding = 0, std430) readonly buffer Header {
    uvec4 words;
} header;
layout(set = 1, binding = 0) uniform texture2DMSArray depth;
layout(set = 1, binding = 1, r32f) uniform writeonly image2DMSArray twin;

void main() {
    uvec4 h = header.words;
    float scale = uintBitsToFloat(h.x);
    float offset = uintBitsToFloat(h.y);
    ivec3 texel = ivec3(gl_GlobalInvocationID.xy, int(gl_GlobalInvocationID.z + h.w));
    if (any(greaterThanEqual(texel.xy, textureSize(depth).xy))) {
        return;
    }
    int samples = textureSamples(depth);
    for (int s = 0; s < samples; s++) {
        float d = fma(texelFetch(depth, texel, s).r, scale, offset);
        if (h.z == 0u) {
            d = clamp(d, 0.0, 1.0);
        }
        imageStore(twin, texel, s, vec4(d));
    }
}
