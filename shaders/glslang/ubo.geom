#version 450
// The `ubo-geometry` delivery: the block of ubo.vert, applied in a geometry shader that emits
// each input triangle as it is, in a loop over its vertices, to the vertex stage's
// gl_Position (the object-space position with w = 1), as geometry shaders are written:
// gl_Position = ((P * V) * M) * position, the same float32 operations as ubo.vert.

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(set = 0, binding = 0) uniform Object {
    mat4 projection;
    mat4 view;
    mat4 model;
    vec4 color;
} ubo;

layout(location = 0) flat out vec4 color;

void main() {
    for (int i = 0; i < 3; i++) {
        gl_Position = ubo.projection * ubo.view * ubo.model * gl_in[i].gl_Position;
        color = ubo.color;
        EmitVertex();
    }
    EndPrimitive();
}
