#version 450
layout(triangles, invocations = 2) in;
layout(triangle_strip, max_vertices = 3) out;
layout(push_constant) uniform Push { mat4 view_proj[2]; } pc;
void main() {
    for (int i = 0; i < 3; i++) {
        gl_Position = pc.view_proj[gl_InvocationID] * gl_in[i].gl_Position;
        gl_ViewportIndex = gl_InvocationID;
        EmitVertex();
    }
}
