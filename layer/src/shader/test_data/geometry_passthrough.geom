#version 450
// Passes each vertex of the triangle through, with its color (a layered or debugging pass).
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(location = 0) in vec4 in_color[];
layout(location = 0) out vec4 color;
void main() {
    for (int i = 0; i < 3; i++) {
        gl_Position = gl_in[i].gl_Position;
        color = in_color[i];
        EmitVertex();
    }
    EndPrimitive();
}
