#version 450
layout(triangles, equal_spacing, ccw) in;
layout(push_constant) uniform Push { mat4 mvp; } pc;
void main() {
    vec3 tc = gl_TessCoord;
    tc.x = 0.9;
    vec4 position = tc.x * gl_in[0].gl_Position + tc.y * gl_in[1].gl_Position + tc.z * gl_in[2].gl_Position;
    gl_Position = pc.mvp * position;
}
