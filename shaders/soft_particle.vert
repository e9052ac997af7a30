#version 450
// Soft-particle vertex shader: `scene.vert`'s push constants and projection, and the clip w
// (the particle's distance along the view axis, for a perspective camera) handed on for the
// fragment shader's fade. The clip position is kept in a local and used twice, as engines
// reuse it.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(location = 0) in vec3 position;
layout(location = 0) out float view_distance;

void main() {
    vec4 clip = pc.mvp * vec4(position, 1.0);
    gl_Position = clip;
    view_distance = clip.w;
}
