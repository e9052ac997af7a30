#version 450
// Fragment shader of the buffer projection deliveries (ubo.vert, ubo_dynamic.vert, ssbo.vert):
// writes the flat color the vertex shader read from the object's buffer.

layout(location = 0) flat in vec4 color;
layout(location = 0) out vec4 out_color;

void main() {
    out_color = color;
}
