#version 450
// Deferred renderers read depth this way: in a later subpass of the render pass that wrote
// it, as an input attachment (`subpassLoad`, the pixel's own value, no sampler). Every
// fragment drawn (the tester draws a quad over the bottom quarter of the image) is shaded
// with the scene's view distance there, as `depth_post.frag` shades its band. Depth 1 (the
// cleared background) shades as the far plane. A reversed value would shade the band wrong.

layout(input_attachment_index = 0, set = 0, binding = 0) uniform subpassInput depth;

layout(location = 0) out vec4 out_color;

// The overlap camera's near and far planes.
const float NEAR = 0.1;
const float FAR = 100.0;

float view_distance(float d) {
    return NEAR * FAR / (FAR - d * (FAR - NEAR));
}

void main() {
    float z = view_distance(subpassLoad(depth).r);
    out_color = vec4(clamp((z - 2.0) / 10.0, 0.0, 1.0), clamp((z - 2.0) / 5.0, 0.0, 1.0),
                     clamp(z / FAR, 0.0, 1.0), 1.0);
}
