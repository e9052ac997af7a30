#version 450
// A single-pass wireframe overlay: each vertex's distances to the opposite edges, in window
// space (from x, y and w of the clip positions), the positions passed through.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(push_constant) uniform Push { vec2 viewport; } pc;
layout(location = 0) noperspective out vec3 distances;
void main() {
    vec2 p0 = pc.viewport * gl_in[0].gl_Position.xy / gl_in[0].gl_Position.w;
    vec2 p1 = pc.viewport * gl_in[1].gl_Position.xy / gl_in[1].gl_Position.w;
    vec2 p2 = pc.viewport * gl_in[2].gl_Position.xy / gl_in[2].gl_Position.w;
    vec2 v0 = p2 - p1;
    vec2 v1 = p2 - p0;
    vec2 v2 = p1 - p0;
    float area = abs(v1.x * v2.y - v1.y * v2.x);
    gl_Position = gl_in[0].gl_Position;
    distances = vec3(area / length(v0), 0.0, 0.0);
    EmitVertex();
    gl_Position = gl_in[1].gl_Position;
    distances = vec3(0.0, area / length(v1), 0.0);
    EmitVertex();
    gl_Position = gl_in[2].gl_Position;
    distances = vec3(0.0, 0.0, area / length(v2));
    EmitVertex();
    EndPrimitive();
}
