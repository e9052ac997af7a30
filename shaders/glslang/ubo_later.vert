#version 450
// Vertex stage of the `ubo-tessellation` delivery: hands the object-space position on to the
// stage that projects it (ubo.tese interpolates it); writes no gl_Position.

layout(location = 0) in vec3 position;
layout(location = 0) out vec3 object_position;

void main() {
    object_position = position;
}
