#version 450
// The `ssbo-columns` delivery: `ssbo`'s buffer (each object's P * V * M, column-major),
// applied as fxc compiles `mul(v, M)` and D3D bytecode translators (DXVK) write it: the input
// register a vec4 (the vec3 position attribute: the fetch gives w = 1), and a temporary
// register reassigned by one multiply and three multiply-adds of the matrix's columns by
// splats of the input (`mul r0, v0.yyyy, cb0[1]`, `mad r0, v0.xxxx, cb0[0], r0`, ...), then
// copied out.

struct Item {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64 (array stride 80)
};

layout(set = 0, binding = 0, std430) readonly buffer Objects {
    Item items[];
} objects;

layout(location = 0) in vec4 v0;
layout(location = 0) flat out vec4 color;

void main() {
    vec4 r0;
    r0 = v0.yyyy * objects.items[gl_InstanceIndex].mvp[1];
    r0 = v0.xxxx * objects.items[gl_InstanceIndex].mvp[0] + r0;
    r0 = v0.zzzz * objects.items[gl_InstanceIndex].mvp[2] + r0;
    r0 = v0.wwww * objects.items[gl_InstanceIndex].mvp[3] + r0;
    gl_Position = r0;
    color = objects.items[gl_InstanceIndex].color;
}
