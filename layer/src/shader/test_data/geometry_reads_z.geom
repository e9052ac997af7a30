#version 450
// Passes the positions through, but also hands their clip z to the fragment stage: z is read
// for something else than the rasterized position.
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
layout(location = 0) out float clip_z;
void main() {
    for (int i = 0; i < 3; i++) {
        gl_Position = gl_in[i].gl_Position;
        clip_z = gl_in[i].gl_Position.z;
        EmitVertex();
    }
    EndPrimitive();
}
