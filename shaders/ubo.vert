#version 450
// The `ubo` projection delivery: the projection, view and model matrices kept apart in one
// uniform block per object, bound as a dynamic uniform buffer (one descriptor, a dynamic
// offset per draw), as many engines store a draw's transforms. Each matrix is the f64 one
// rounded once to float32; the GPU composes them: ((P * V) * M) * position. The flat color
// passes on to flat_color.frag. No push constants.

layout(set = 0, binding = 0) uniform Object {
    mat4 projection; // offset 0, column-major, matrix stride 16
    mat4 view;       // offset 64
    mat4 model;      // offset 128
    vec4 color;      // offset 192 (the block is 208 bytes)
} ubo;

layout(location = 0) in vec3 position;
layout(location = 0) flat out vec4 color;

void main() {
    gl_Position = ubo.projection * ubo.view * ubo.model * vec4(position, 1.0);
    color = ubo.color;
}
