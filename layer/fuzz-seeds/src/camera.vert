#version 450
// Nested push-constant struct, an array of matrices, a helper function and a loop: the
// analysis follows the data flow through calls, locals and the outermost multiply.
struct Camera { vec4 eye; mat4 view_proj; };
layout(push_constant) uniform PC { mat4 model[2]; Camera camera; uint flags; } pc;
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 0) out vec3 world_normal;

vec4 apply(mat4 m, vec4 p) { return m * p; }

void main() {
    vec4 world = pc.model[pc.flags & 1u] * vec4(position, 1.0);
    for (int i = 0; i < 2; ++i) {
        world.xyz += 0.0 * normal;
    }
    world_normal = mat3(pc.model[0]) * normal;
    gl_Position = apply(pc.camera.view_proj, world);
}
