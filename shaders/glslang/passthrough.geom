#version 450
// The `ubo-passthrough-geometry` delivery: ubo.vert projects, and this geometry shader passes
// each triangle through as it is (gl_Position = gl_in[i].gl_Position, the color with it), as
// layered, debugging or wireframe passes do. It reads x, y and w of the positions (a
// wireframe overlay's edge distances, here only a test that the triangle is in front of the
// camera, which every triangle of the scenes is), never z: the vertex stage is the one revz
// rewrites.

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(location = 0) flat in vec4 in_color[];
layout(location = 0) flat out vec4 color;

void main() {
    if (gl_in[0].gl_Position.w <= 0.0 && gl_in[1].gl_Position.w <= 0.0
            && gl_in[2].gl_Position.w <= 0.0) {
        return;
    }
    for (int i = 0; i < 3; i++) {
        gl_Position = gl_in[i].gl_Position;
        color = in_color[i];
        EmitVertex();
    }
    EndPrimitive();
}
