#version 460
// gl_BaseInstance needs the DrawParameters capability (which naga rejects, and the analysis
// strips); gl_PointSize makes a gl_PerVertex block with several members.
layout(push_constant) uniform PC { mat4 mvp; vec4 offsets[4]; } pc;
layout(location = 0) in vec3 position;
layout(location = 0) flat out int base;
void main() {
    base = gl_BaseInstance + gl_DrawID;
    gl_PointSize = 1.0;
    gl_Position = pc.mvp * vec4(position + pc.offsets[gl_BaseInstance & 3].xyz, 1.0);
}
