#version 450
layout(triangles, invocations = 2) in;
layout(triangle_strip, max_vertices = 3) out;
layout(push_constant) uniform Push { mat4 view_proj[2]; } pc;
layout(location = 0) in vec3 world[];
void main() {
    for (int i = 0; i < 3; i++) {
        gl_Position = pc.view_proj[gl_InvocationID] * vec4(world[i], 1.0);
        gl_ViewportIndex = gl_InvocationID;
        EmitVertex();
    }
}
