#version 450
// The `ubo-dynamic` projection delivery: a per-frame uniform buffer with the precomposed
// view-projection (P * V in f64, rounded once to float32) and a dynamic uniform buffer of
// per-object blocks (model matrix and color) at an aligned stride, one dynamic offset per
// draw. gl_Position = view_proj * (model * position). No push constants.

layout(set = 0, binding = 0) uniform Frame {
    mat4 view_proj; // offset 0, column-major, matrix stride 16
} frame;

layout(set = 0, binding = 1) uniform Object {
    mat4 model;  // offset 0
    vec4 color;  // offset 64 (the block is 80 bytes)
} object;

layout(location = 0) in vec3 position;
layout(location = 0) flat out vec4 color;

void main() {
    gl_Position = frame.view_proj * object.model * vec4(position, 1.0);
    color = object.color;
}
