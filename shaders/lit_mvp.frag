#version 450
// Lit fragment shader of lit_mvp.vert: the face normal from the screen-space derivatives of
// the view vector (the meshes have no normals; every face is flat), turned toward the viewer,
// a fixed light direction, pc.color times ambient + diffuse, plus a white specular highlight
// (Phong, exponent 32). Everything is computed in the space of the vertex shader's `pos`
// (clip x, y and z), so the pushed matrix's depth row enters the normal, the view vector and
// the highlight.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16
    vec4 color; // offset 64
} pc;

layout(location = 0) in vec3 view_vec;
layout(location = 0) out vec4 out_color;

// The direction toward the light (normalized in main).
const vec3 LIGHT = vec3(-0.35, -0.55, -0.75);
const float AMBIENT = 0.3;
const float SHININESS = 32.0;
const float SPECULAR = 0.5;

void main() {
    vec3 l = normalize(LIGHT);
    vec3 v = normalize(view_vec);
    vec3 n = normalize(cross(dFdx(view_vec), dFdy(view_vec)));
    if (dot(n, v) < 0.0) {
        n = -n;
    }
    float diffuse = max(dot(n, l), 0.0);
    float specular = pow(max(dot(reflect(-l, n), v), 0.0), SHININESS);
    out_color = vec4(pc.color.rgb * (AMBIENT + (1.0 - AMBIENT) * diffuse) + SPECULAR * specular,
                     pc.color.a);
}
