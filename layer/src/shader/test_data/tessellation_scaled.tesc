#version 450
// Positions changed on their way: not carried on.
layout(vertices = 3) out;
void main() {
    gl_out[gl_InvocationID].gl_Position = 0.5 * gl_in[gl_InvocationID].gl_Position;
    gl_TessLevelInner[0] = 1.0;
    gl_TessLevelOuter[0] = 1.0;
    gl_TessLevelOuter[1] = 1.0;
    gl_TessLevelOuter[2] = 1.0;
}
