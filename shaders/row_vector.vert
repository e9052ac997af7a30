#version 450
// Row-vector vertex shader (the `row-major` scene's second program): the other HLSL habit,
// `mul(position, matrix)` with the vector on the left. The member is an ordinary column-major
// mat4 X, and `v * X` is `transpose(X) * v`: the transform the shader applies is X transposed,
// so the bytes in memory are the rows of that transform, exactly as for row_major.vert.

layout(push_constant) uniform PushConstants {
    mat4 mvp_transposed; // offset 0, column-major: the transpose of the applied transform
    vec4 color;          // offset 64
} pc;

layout(location = 0) in vec3 position;

void main() {
    gl_Position = vec4(position, 1.0) * pc.mvp_transposed;
}
