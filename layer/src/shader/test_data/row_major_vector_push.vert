#version 450
// HLSL's `mul(v, M)` on a row-major push-constant member, as glslang compiles GLSL written
// that way: `vec4(p, 1.0) * pc.m` (OpVectorTimesMatrix) with `m` decorated RowMajor.
layout(push_constant) uniform P { layout(row_major) mat4 m; } pc;
layout(location = 0) in vec3 p;
void main() { gl_Position = vec4(p, 1.0) * pc.m; }
