#version 450
// Model and view-projection as two push-constant matrices (the `model-view-projection-pair`
// scene): gl_Position = view_proj * (model * position). Only the outer matrix, view_proj, is a
// projection; model is affine and must be left alone by anything that rewrites projections.
// The two matrices take all 128 bytes push constants are guaranteed to have (lavapipe has no
// more), so the flat color comes from a uniform buffer, indexed by the draw's firstInstance
// (the object's index).

layout(push_constant) uniform PushConstants {
    mat4 model;     // offset 0, column-major, matrix stride 16
    mat4 view_proj; // offset 64, column-major, matrix stride 16
} pc;

layout(location = 0) in vec3 position;
layout(location = 0) flat out uint object_index;

void main() {
    gl_Position = pc.view_proj * (pc.model * vec4(position, 1.0));
    object_index = uint(gl_InstanceIndex);
}
