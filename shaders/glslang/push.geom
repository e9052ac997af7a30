#version 450
// The `push-geometry` delivery: scene.vert's push constants (`mvp`, then `color` for
// scene.frag), the product applied in a geometry shader to the vertex stage's gl_Position
// (ubo_position.vert: the object-space position, w = 1); the layout's one range names the
// vertex, geometry and fragment stages.

layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;

layout(push_constant) uniform Push {
    mat4 mvp;
    vec4 color;
} pc;

void main() {
    for (int i = 0; i < 3; i++) {
        gl_Position = pc.mvp * gl_in[i].gl_Position;
        EmitVertex();
    }
    EndPrimitive();
}
