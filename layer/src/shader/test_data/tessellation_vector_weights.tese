#version 450
// The barycentric sum written with a swizzle of gl_TessCoord loaded whole, products first.
layout(triangles, equal_spacing, ccw) in;
void main() {
    vec3 c = gl_TessCoord;
    vec4 a = gl_in[2].gl_Position * c.z;
    vec4 b = c.x * gl_in[0].gl_Position;
    gl_Position = a + (b + c.y * gl_in[1].gl_Position);
}
