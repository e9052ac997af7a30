#version 450
// Scene vertex shader: the projection (a precomposed model-view-projection matrix) arrives in
// push constants and feeds gl_Position directly, exactly as in most real applications.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(location = 0) in vec3 position;

void main() {
    gl_Position = pc.mvp * vec4(position, 1.0);
}
