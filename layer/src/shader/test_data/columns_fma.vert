#version 450
// A projection written out by columns with fused multiply-adds, as a backend that fuses
// (Mesa's NIR, `ffma`) emits it: fma(c3, p.w, fma(c2, p.z, fma(c1, p.y, c0 * p.x))).
layout(push_constant) uniform Push { mat4 view_proj; } pc;
layout(location = 0) in vec3 position;
void main() {
    mat4 m = pc.view_proj;
    vec4 p = vec4(position, 1.0);
    gl_Position = fma(m[3], vec4(p.w), fma(m[2], vec4(p.z), fma(m[1], vec4(p.y), m[0] * vec4(p.x))));
}
