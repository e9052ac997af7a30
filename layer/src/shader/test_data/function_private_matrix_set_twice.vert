#version 450
// Found in review (issue #41): whether a fit in a called function describes the stored vertex.
layout(set = 0, binding = 0) uniform Frame { mat4 p[2]; } frame;
layout(location = 0) in vec3 position;
mat4 chosen;
void pick(int i) { chosen = frame.p[i]; }
void main() { pick(0); vec4 r = chosen * vec4(position, 1.0); pick(1); gl_Position = r; }
