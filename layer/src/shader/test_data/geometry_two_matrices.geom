#version 450
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(set = 0, binding = 0) uniform Frame { mat4 view_proj; mat4 other; } frame;
layout(location = 0) in vec3 world[];
void main() {
    gl_Position = frame.view_proj * vec4(world[0], 1.0);
    EmitVertex();
    gl_Position = frame.other * vec4(world[1], 1.0);
    EmitVertex();
    gl_Position = frame.view_proj * vec4(world[2], 1.0);
    EmitVertex();
}
