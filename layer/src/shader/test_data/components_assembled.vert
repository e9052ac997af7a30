#version 450
// As D3D bytecode translators (DXVK) write a vertex shader: the constant buffer an array of
// vec4s, the input register a vec4 (its w the attribute fetch's 1), the output register a
// private vec4 written one component at a time by four dot products (`dp4 o0.x, v0, cb0[0]`
// ...) in the shader's function, which the entry point calls and then copies the register
// into gl_Position.
layout(set = 0, binding = 0) uniform cb0_block { vec4 cb0[4]; };
layout(location = 0) in vec4 v0;
vec4 o0;
void vs_main() {
    o0.x = dot(v0, cb0[0]);
    o0.y = dot(v0, cb0[1]);
    o0.z = dot(v0, cb0[2]);
    o0.w = dot(v0, cb0[3]);
}
void main() {
    vs_main();
    gl_Position = o0;
}
