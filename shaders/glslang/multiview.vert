#version 450
#extension GL_EXT_multiview : require
// The `multiview` scenes' vertex shader: one draw renders every view of the pass's view mask
// (VK_KHR_multiview), each into its own array layer, as stereo (VR) renderers draw both eyes
// and engines draw a cube shadow map's faces in one pass. The views' view-projection matrices
// (P * V per eye in f64, each rounded once to float32) are in a uniform buffer indexed by
// gl_ViewIndex; the object's model matrix and its color are pushed (the layout of
// scene.vert's push constants, so that scene.frag reads the color at 64).

layout(set = 0, binding = 0) uniform Views {
    mat4 view_projection[2]; // offsets 0 and 64, column-major, matrix stride 16
} views;

layout(push_constant) uniform PushConstants {
    mat4 model;  // offset 0, column-major, matrix stride 16
    vec4 color;  // offset 64
} pc;

layout(location = 0) in vec3 position;

void main() {
    gl_Position = views.view_projection[gl_ViewIndex] * pc.model * vec4(position, 1.0);
}
