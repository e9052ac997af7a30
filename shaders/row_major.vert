#version 450
// Row-major vertex shader (the `row-major` scene), as HLSL compilers emit it: the clip-space
// transform is a push-constant member decorated RowMajor, so its rows lie consecutively in
// memory (the CPU writes the transpose of what a column-major GLSL application writes), and
// the shader computes `mvp * position` with the matrix as stored.
//
// naga's GLSL front end rejects `layout(row_major)`, so the member is declared as a plain mat4
// here and the directive below makes build.rs decorate it RowMajor instead of ColMajor in the
// SPIR-V naga writes (one decoration word; the module is checked by spirv-val in the tests).
// revz-build: RowMajor PushConstants.mvp

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, RowMajor (see above), matrix stride 16
    vec4 color; // offset 64
} pc;

layout(location = 0) in vec3 position;

void main() {
    gl_Position = pc.mvp * vec4(position, 1.0);
}
