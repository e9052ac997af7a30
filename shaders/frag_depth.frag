#version 450
// FragDepth fragment shader (the `frag-depth` scene): the flat push-constant color of
// scene.frag, and a depth of its own: gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z, which pushes
// the surface back (a surface at standard depth D is stored and tested at (1 + D) / 2). The
// shader both reads the rasterized depth and writes the fragment's depth, so a layer that
// reverses depth must map the value it reads (gl_FragCoord.z) and the value it writes
// (gl_FragDepth) between standard and reversed depth.

layout(push_constant) uniform PushConstants {
    mat4 mvp;   // offset 0, column-major, matrix stride 16 (read by scene.vert)
    vec4 color; // offset 64
} pc;

layout(location = 0) out vec4 out_color;

void main() {
    out_color = pc.color;
    gl_FragDepth = 0.5 + 0.5 * gl_FragCoord.z;
}
