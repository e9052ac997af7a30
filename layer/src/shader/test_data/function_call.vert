#version 450
// The projection applied in a function (glslang -O0 keeps the call; the argument goes
// through a function variable).
layout(set = 0, binding = 0) uniform Object { mat4 projection; mat4 view; mat4 model; } ubo;
layout(location = 0) in vec3 position;
vec4 project(vec3 p) {
    return ubo.projection * ubo.view * ubo.model * vec4(p, 1.0);
}
void main() {
    gl_Position = project(position);
}
