#version 450
// The `push-split` delivery's fragment stage: the color at bytes 64..80, in the fragment
// stage's own push-constant range.

layout(push_constant) uniform Push {
    layout(offset = 64) vec4 color;
} pc;

layout(location = 0) out vec4 out_color;

void main() {
    out_color = pc.color;
}
