#version 450
// The `ssbo-rows` delivery: the `ssbo` delivery's precomposed P * V * M, stored as its four
// rows, applied as four dot products (HLSL's `dp4`, as D3D bytecode and its translators write
// a projection): gl_Position = vec4(dot(r0, p), dot(r1, p), dot(r2, p), dot(r3, p)).

struct Item {
    vec4 rows[4]; // offset 0: row i of the clip transform at 16 i
    vec4 color;   // offset 64 (array stride 80)
};

layout(set = 0, binding = 0, std430) readonly buffer Objects {
    Item items[];
} objects;

layout(location = 0) in vec3 position;
layout(location = 0) flat out vec4 color;

void main() {
    vec4 p = vec4(position, 1.0);
    gl_Position = vec4(dot(objects.items[gl_InstanceIndex].rows[0], p),
                       dot(objects.items[gl_InstanceIndex].rows[1], p),
                       dot(objects.items[gl_InstanceIndex].rows[2], p),
                       dot(objects.items[gl_InstanceIndex].rows[3], p));
    color = objects.items[gl_InstanceIndex].color;
}
