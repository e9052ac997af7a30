#version 450
// depth_less, discard, a loop and a store to gl_FragDepth inside a function.
layout(depth_less) out float gl_FragDepth;
layout(location = 0) in vec2 uv;
layout(location = 0) out vec4 out_color;
layout(set = 0, binding = 0) uniform sampler2D decal;
void write_depth(float d) { gl_FragDepth = d; }
void main() {
    vec4 texel = texture(decal, uv);
    if (texel.a < 0.01) {
        discard;
    }
    float d = gl_FragCoord.z;
    for (int i = 0; i < 3; ++i) {
        d = d * 0.99;
    }
    write_depth(d);
    out_color = texel;
}
