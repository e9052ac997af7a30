#version 450
// Tessellation control stage of the `ubo-projecting-tessellation` delivery: after
// ubo_position.vert (which hands the object-space position on as gl_Position with w = 1),
// each triangle one patch of three control points, the positions copied as they are,
// tessellated once (every level 1: the patch itself).

layout(vertices = 3) out;

void main() {
    gl_out[gl_InvocationID].gl_Position = gl_in[gl_InvocationID].gl_Position;
    if (gl_InvocationID == 0) {
        gl_TessLevelInner[0] = 1.0;
        gl_TessLevelOuter[0] = 1.0;
        gl_TessLevelOuter[1] = 1.0;
        gl_TessLevelOuter[2] = 1.0;
    }
}
