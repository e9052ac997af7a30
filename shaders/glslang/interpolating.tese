#version 450
// The `ubo-interpolating-tessellation` delivery: the clip positions ubo.vert projected,
// interpolated at the patch point with its barycentric coordinates (at level 1 a corner:
// 1 * p + 0 * q + 0 * r, the corner exactly), as tessellation stages that only subdivide do.

layout(triangles, equal_spacing, ccw) in;

layout(location = 0) flat in vec4 control_color[];
layout(location = 0) flat out vec4 color;

void main() {
    gl_Position = gl_TessCoord.x * gl_in[0].gl_Position
        + gl_TessCoord.y * gl_in[1].gl_Position
        + gl_TessCoord.z * gl_in[2].gl_Position;
    color = control_color[0];
}
