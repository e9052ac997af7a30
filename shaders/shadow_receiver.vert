#version 450
// Shadow-receiver vertex shader (the `shadow-map` scene's main pass). The camera projection
// arrives exactly as in scene.vert (a precomposed MVP in push constants feeding gl_Position);
// the light's orthographic model-view-projection of the drawn object comes from a uniform
// buffer, indexed by the draw's firstInstance (the object's index), and goes to the fragment
// shader as the shadow-map coordinate.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(set = 0, binding = 0) uniform Light {
    mat4 light_mvp[16];
} light;

layout(location = 0) in vec3 position;
layout(location = 0) out vec4 light_clip;

void main() {
    gl_Position = pc.mvp * vec4(position, 1.0);
    light_clip = light.light_mvp[gl_InstanceIndex] * vec4(position, 1.0);
}
