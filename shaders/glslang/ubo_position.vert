#version 450
// Vertex stage of the `ubo-geometry` delivery: hands the object-space position on as
// gl_Position with w = 1, which ubo.geom projects (gl_in[i].gl_Position).

layout(location = 0) in vec3 position;

void main() {
    gl_Position = vec4(position, 1.0);
}
