#version 450
// Quads interpolated bilinearly with mix(): affine whatever the coordinates.
layout(quads, equal_spacing, ccw) in;
void main() {
    vec4 bottom = mix(gl_in[0].gl_Position, gl_in[1].gl_Position, gl_TessCoord.x);
    vec4 top = mix(gl_in[3].gl_Position, gl_in[2].gl_Position, gl_TessCoord.x);
    gl_Position = mix(bottom, top, gl_TessCoord.y);
}
