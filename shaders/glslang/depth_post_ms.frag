#version 450
// Post pass over a multisampled depth image (SSAO and edge detection on MSAA depth read it
// this way, and OpenGL through Zink reads multisampled depth textures so): the bottom 45% of
// the image (the ground, the near cube's lower half and its silhouettes) is overwritten with
// a shade of the view distances of the pixel's four depth samples, each read with a texel
// fetch of its own sample: red from the nearest, green from the farthest, blue from their
// spread (on silhouettes, where the samples cover two surfaces). The rest of the image is
// left as it is. Depth 1 (the cleared background) shades as the far plane. Reversed values
// would shade the whole band black (everything at the near plane).

layout(set = 0, binding = 0) uniform texture2DMS scene_depth;
layout(set = 0, binding = 1) uniform sampler nearest_sampler;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;
const int SAMPLES = 4;

float view_distance(float depth) {
    return NEAR * FAR / (FAR - depth * (FAR - NEAR));
}

void main() {
    ivec2 size = textureSize(sampler2DMS(scene_depth, nearest_sampler));
    if (gl_FragCoord.y < 0.55 * float(size.y)) {
        discard;
    }
    ivec2 pixel = ivec2(gl_FragCoord.xy);
    float nearest = 1.0;
    float farthest = 0.0;
    for (int s = 0; s < SAMPLES; s++) {
        float depth = texelFetch(sampler2DMS(scene_depth, nearest_sampler), pixel, s).r;
        nearest = min(nearest, depth);
        farthest = max(farthest, depth);
    }
    float near_z = view_distance(nearest);
    float far_z = view_distance(farthest);
    out_color = vec4(clamp((near_z - 2.0) / 10.0, 0.0, 1.0), clamp((far_z - 2.0) / 10.0, 0.0, 1.0),
                     clamp((far_z - near_z) / 2.0, 0.0, 1.0), 1.0);
}
