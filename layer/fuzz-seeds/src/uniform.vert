#version 450
// The projection in a uniform buffer, the model in push constants: not from push constants.
layout(set = 0, binding = 0) uniform Camera { mat4 proj; mat4 view; } camera;
layout(push_constant) uniform PC { mat4 model; } pc;
layout(location = 0) in vec4 position;
void main() {
    gl_Position = camera.proj * camera.view * pc.model * position;
}
