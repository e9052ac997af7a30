#version 450
layout(quads, equal_spacing, ccw) in;
layout(set = 0, binding = 0) uniform Matrices { mat4 projection; mat4 modelview; } ubo;
layout(set = 0, binding = 1) uniform sampler2D height;
void main() {
    vec4 a = mix(gl_in[0].gl_Position, gl_in[1].gl_Position, gl_TessCoord.x);
    vec4 b = mix(gl_in[3].gl_Position, gl_in[2].gl_Position, gl_TessCoord.x);
    vec4 position = mix(a, b, gl_TessCoord.y);
    position.y -= textureLod(height, gl_TessCoord.xy, 0.0).r * position.z;
    gl_Position = ubo.projection * ubo.modelview * position;
}
