#version 450
// Found in review (issue #41): whether a fit in a called function describes the stored vertex.
layout(set = 0, binding = 0) uniform Frame { vec4 rows[4]; } frame;
layout(location = 0) in vec3 position;
vec4 project(vec3 q) { vec4 p = vec4(q, 1.0); return vec4(dot(frame.rows[0], p), dot(p, frame.rows[1]), dot(frame.rows[2], p), dot(p, frame.rows[3])); }
void main() { gl_Position = project(position); }
