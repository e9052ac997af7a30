#version 450
layout(triangles, equal_spacing, ccw) in;
void main() {
    vec4 position = gl_TessCoord.x * gl_in[0].gl_Position + gl_TessCoord.y * gl_in[1].gl_Position + gl_TessCoord.z * gl_in[2].gl_Position;
    float f = modf(7.5, position.w);
    gl_Position = position;
}
