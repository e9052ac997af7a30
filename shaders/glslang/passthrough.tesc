#version 450
// Tessellation control stage of the `ubo-tessellation` delivery: each triangle one patch of
// three control points, tessellated once (every level 1: the patch itself).

layout(vertices = 3) out;

layout(location = 0) in vec3 object_position[];
layout(location = 0) out vec3 control_position[];

void main() {
    control_position[gl_InvocationID] = object_position[gl_InvocationID];
    if (gl_InvocationID == 0) {
        gl_TessLevelInner[0] = 1.0;
        gl_TessLevelOuter[0] = 1.0;
        gl_TessLevelOuter[1] = 1.0;
        gl_TessLevelOuter[2] = 1.0;
    }
}
