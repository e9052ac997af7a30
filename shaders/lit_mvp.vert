#version 450
// Lit vertex shader (the `lit-mvp` scene): the precomposed MVP in push constants, exactly as
// in scene.vert, and the same clip position used for lighting too, as samples and engines do:
// gl_Position and the view vector both come from `pos`. A layer that rewrites the pushed
// matrix's depth row changes the view vector (its z is the depth row's output) and so the
// shading; one that rewrites only the store to gl_Position leaves the image unchanged.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(location = 0) in vec3 position;
layout(location = 0) out vec3 view_vec;

void main() {
    vec4 pos = pc.mvp * vec4(position, 1.0);
    gl_Position = pos;
    view_vec = -pos.xyz;
}
