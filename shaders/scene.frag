#version 450
// Scene fragment shader: flat per-object color from the push constants shared with scene.vert.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(location = 0) out vec4 out_color;

void main() {
    out_color = pc.color;
}
