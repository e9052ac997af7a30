#version 450
// Fragment shader of mvp_pair.vert: the object's flat color from the uniform buffer of
// per-object colors.

layout(set = 0, binding = 0) uniform Colors {
    vec4 colors[16];
} object_colors;

layout(location = 0) flat in uint object_index;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = object_colors.colors[object_index];
}
