#version 450
// A depth pyramid level, as Hi-Z occlusion culling builds one: the nearest and the farthest
// depth of each 4 x 4 tile of the main depth image, read with texel fetches in a compute
// shader, written to a storage buffer (row-major tiles) that a later pass shades from.

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform texture2D scene_depth;
layout(set = 0, binding = 1) uniform sampler nearest_sampler;
layout(set = 0, binding = 2, std430) buffer Tiles {
    vec2 nearest_farthest[];
} tiles;

void main() {
    ivec2 size = textureSize(sampler2D(scene_depth, nearest_sampler), 0);
    ivec2 tile_count = size / 4;
    ivec2 tile = ivec2(gl_GlobalInvocationID.xy);
    if (tile.x >= tile_count.x || tile.y >= tile_count.y) {
        return;
    }
    float nearest = 1.0;
    float farthest = 0.0;
    for (int y = 0; y < 4; y++) {
        for (int x = 0; x < 4; x++) {
            float depth = texelFetch(sampler2D(scene_depth, nearest_sampler), tile * 4 + ivec2(x, y), 0).r;
            nearest = min(nearest, depth);
            farthest = max(farthest, depth);
        }
    }
    tiles.nearest_farthest[tile.y * tile_count.x + tile.x] = vec2(nearest, farthest);
}
