#version 450
// The `ssbo` projection delivery: every object's precomposed P * V * M (f64, rounded once to
// float32) and color in a read-only storage buffer, indexed by the instance index: each
// object is drawn with one instance whose firstInstance is its index. No push constants.

struct Item {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64 (array stride 80)
};

layout(set = 0, binding = 0, std430) readonly buffer Objects {
    Item items[];
} objects;

layout(location = 0) in vec3 position;
layout(location = 0) flat out vec4 color;

void main() {
    gl_Position = objects.items[gl_InstanceIndex].mvp * vec4(position, 1.0);
    color = objects.items[gl_InstanceIndex].color;
}
