#version 450
layout(triangles, equal_spacing, ccw) in;
layout(push_constant) uniform Push { mat4 mvp; } pc;
void main() {
    vec4 position = gl_TessCoord.x * gl_in[0].gl_Position + gl_TessCoord.y * gl_in[1].gl_Position + gl_TessCoord.z * gl_in[2].gl_Position;
    float f = modf(7.5, position.w);
    gl_Position = pc.mvp * position;
}
