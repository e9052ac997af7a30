#version 450
// Shades the top quarter of the image from the depth pyramid level `depth_tiles.comp` built
// (each 4 x 4 tile's nearest and farthest depth): red from the farthest view distance, green
// from the nearest, blue from their spread. The rest of the image is left as it is. A pyramid
// built from reversed values would shade the whole band wrong.

layout(set = 0, binding = 0) uniform texture2D scene_depth;
layout(set = 0, binding = 1) uniform sampler nearest_sampler;
layout(set = 0, binding = 2, std430) readonly buffer Tiles {
    vec2 nearest_farthest[];
} tiles;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;

float view_distance(float depth) {
    return NEAR * FAR / (FAR - depth * (FAR - NEAR));
}

void main() {
    // Only the size of the depth image is read here (its values come from the tiles).
    vec2 size = vec2(textureSize(sampler2D(scene_depth, nearest_sampler), 0));
    if (gl_FragCoord.y >= 0.25 * size.y) {
        discard;
    }
    int columns = int(size.x) / 4;
    ivec2 tile = ivec2(gl_FragCoord.xy) / 4;
    vec2 range = tiles.nearest_farthest[tile.y * columns + tile.x];
    float near_z = view_distance(range.x);
    float far_z = view_distance(range.y);
    out_color = vec4(clamp((far_z - 2.0) / 10.0, 0.0, 1.0), clamp((near_z - 2.0) / 10.0, 0.0, 1.0),
                     clamp((far_z - near_z) / 2.0, 0.0, 1.0), 1.0);
}
