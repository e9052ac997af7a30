#version 450
// The `ssbo-registers` delivery: the `ssbo-rows` buffer (each object's P * V * M as its four
// rows), applied as D3D bytecode translators (DXVK) write a vertex shader: the input register
// a vec4 (the vec3 position attribute: the fetch gives w = 1), the output registers private
// vec4s, the position written one component at a time by four dot products
// (`dp4 o0.x, v0, cb0[0]` ...) in the shader's function, which the entry point calls and then
// copies the registers out.

struct Item {
    vec4 rows[4]; // offset 0: row i of the clip transform at 16 i
    vec4 color;   // offset 64 (array stride 80)
};

layout(set = 0, binding = 0, std430) readonly buffer Objects {
    Item items[];
} objects;

layout(location = 0) in vec4 v0;
layout(location = 0) flat out vec4 color;

vec4 o0;
vec4 o1;

void vs_main() {
    o0.x = dot(v0, objects.items[gl_InstanceIndex].rows[0]);
    o0.y = dot(v0, objects.items[gl_InstanceIndex].rows[1]);
    o0.z = dot(v0, objects.items[gl_InstanceIndex].rows[2]);
    o0.w = dot(v0, objects.items[gl_InstanceIndex].rows[3]);
    o1 = objects.items[gl_InstanceIndex].color;
}

void main() {
    vs_main();
    gl_Position = o0;
    color = o1;
}
