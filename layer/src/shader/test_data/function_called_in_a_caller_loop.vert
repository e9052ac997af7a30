#version 450
// Found in review (issue #41): whether a fit in a called function describes the stored vertex.
layout(set = 0, binding = 0) uniform Frame { mat4 p[2]; } frame;
layout(location = 0) in vec3 position;
void setPos(int i) { vec4 q = frame.p[i] * vec4(position, 1.0); if (i == 0) gl_Position = q; }
void main() { for (int i = 0; i < 2; i++) setPos(i); }
