#version 450
// The `push-split` delivery's vertex stage: the push constants of scene.vert, the matrix in the
// vertex stage's own range (bytes 0..64, VERTEX) and the color in the fragment stage's
// (64..80, FRAGMENT), as applications that give each stage its range lay them out.

layout(push_constant) uniform Push {
    mat4 mvp;
} pc;

layout(location = 0) in vec3 position;

void main() {
    gl_Position = pc.mvp * vec4(position, 1.0);
}
