#version 450
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(set = 0, binding = 0) uniform Frame { mat4 view_proj; } frame;
layout(location = 0) in vec3 world[];
void main() {
    for (int i = 0; i < 3; i++) {
        if (world[i].x > 0.0) {
            gl_Position = frame.view_proj * vec4(world[i], 1.0);
        }
        EmitVertex();
    }
}
