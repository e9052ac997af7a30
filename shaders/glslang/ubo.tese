#version 450
// The `ubo-tessellation` delivery: the block of ubo.vert, applied in a tessellation evaluation
// shader to the patch point (at level 1 a corner: 1 * p + 0 * q + 0 * r, the corner exactly):
// gl_Position = ((P * V) * M) * position, the same float32 operations as ubo.vert.

layout(triangles, equal_spacing, ccw) in;

layout(set = 0, binding = 0) uniform Object {
    mat4 projection;
    mat4 view;
    mat4 model;
    vec4 color;
} ubo;

layout(location = 0) in vec3 control_position[];
layout(location = 0) flat out vec4 color;

void main() {
    vec3 position = gl_TessCoord.x * control_position[0]
        + gl_TessCoord.y * control_position[1]
        + gl_TessCoord.z * control_position[2];
    gl_Position = ubo.projection * ubo.view * ubo.model * vec4(position, 1.0);
    color = ubo.color;
}
