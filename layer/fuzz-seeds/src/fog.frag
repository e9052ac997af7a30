#version 450
// Reads gl_FragCoord.z in several ways (component, swizzle, whole vector) and writes a
// conservative depth: layout(depth_greater).
layout(depth_greater) out float gl_FragDepth;
layout(location = 0) in vec4 color;
layout(location = 0) out vec4 out_color;
layout(push_constant) uniform PC { vec4 fog; float bias; } pc;
void main() {
    float z = gl_FragCoord.z;
    vec2 zw = gl_FragCoord.zw;
    vec4 coord = gl_FragCoord;
    float fog = clamp((z - pc.fog.x) * pc.fog.y, 0.0, 1.0);
    out_color = mix(color, vec4(pc.fog.zzz, 1.0), fog) + vec4(coord.xy * 0.0, zw * 0.0);
    if (fog > 0.5) {
        gl_FragDepth = z + pc.bias;
    } else {
        gl_FragDepth = coord.z;
    }
}
