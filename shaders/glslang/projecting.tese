#version 450
// The `ubo-projecting-tessellation` delivery: the patch's object-space positions (which
// ubo_position.vert hands on with w = 1) interpolated at the patch point with its barycentric
// coordinates, displaced along y as terrain is from a height map (by a term that is 0 at
// every corner, so at level 1 the corner exactly), and projected here with the block of
// ubo.vert: gl_Position = ((P * V) * M) * position, the same float32 operations as ubo.vert.

layout(triangles, equal_spacing, ccw) in;

layout(set = 0, binding = 0) uniform Object {
    mat4 projection;
    mat4 view;
    mat4 model;
    vec4 color;
} ubo;

layout(location = 0) flat out vec4 color;

void main() {
    vec4 position = gl_TessCoord.x * gl_in[0].gl_Position
        + gl_TessCoord.y * gl_in[1].gl_Position
        + gl_TessCoord.z * gl_in[2].gl_Position;
    position.y += gl_TessCoord.x * gl_TessCoord.y * 0.5;
    gl_Position = ubo.projection * ubo.view * ubo.model * position;
    color = ubo.color;
}
