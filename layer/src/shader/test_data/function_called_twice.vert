#version 450
// The projection in a function called twice: a fit in it describes the last call, whichever
// call's value Position holds.
layout(set = 0, binding = 0) uniform Object { mat4 projection[2]; } ubo;
layout(location = 0) in vec3 position;
layout(location = 0) out vec4 other;
vec4 project(vec3 p, int i) {
    return ubo.projection[i] * vec4(p, 1.0);
}
void main() {
    gl_Position = project(position, 0);
    other = project(position, 1);
}
