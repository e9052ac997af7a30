#version 450
// Tessellation evaluation stage of the `ubo-tessellated-geometry` delivery: after
// ubo_position.vert (object-space positions with w = 1) and corner_positions.tesc (which
// copies them), the patch's positions interpolated at the patch point with its barycentric
// coordinates (at level 1 a corner: 1 * p + 0 * q + 0 * r, the corner exactly), w = 1 kept;
// ubo.geom then projects them (gl_in[i].gl_Position), as a geometry stage after tessellation
// that builds or culls primitives does.

layout(triangles, equal_spacing, ccw) in;

void main() {
    gl_Position = gl_TessCoord.x * gl_in[0].gl_Position
        + gl_TessCoord.y * gl_in[1].gl_Position
        + gl_TessCoord.z * gl_in[2].gl_Position;
}
