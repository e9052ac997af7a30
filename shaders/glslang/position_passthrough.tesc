#version 450
// Tessellation control stage of the `ubo-interpolating-tessellation` delivery: after ubo.vert
// (which projects), each triangle one patch of three control points, the clip positions and
// colors passed through as they are, tessellated once (every level 1: the patch itself).

layout(vertices = 3) out;

layout(location = 0) flat in vec4 in_color[];
layout(location = 0) flat out vec4 control_color[];

void main() {
    gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;
    control_color[gl_InvocationID] = in_color[gl_InvocationID];
    if (gl_InvocationID == 0) {
        gl_TessLevelInner[0] = 1.0;
        gl_TessLevelOuter[0] = 1.0;
        gl_TessLevelOuter[1] = 1.0;
        gl_TessLevelOuter[2] = 1.0;
    }
}
