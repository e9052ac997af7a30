#version 450
// A projection applied as four dot products of the matrix's rows (as HLSL's `dp4` and D3D
// bytecode translators write it), the rows in a uniform buffer of vec4s, the dots' operands
// in either order.
layout(set = 0, binding = 0) uniform Frame { vec4 rows[4]; } frame;
layout(location = 0) in vec3 position;
void main() {
    vec4 p = vec4(position, 1.0);
    gl_Position = vec4(dot(frame.rows[0], p), dot(p, frame.rows[1]), dot(frame.rows[2], p),
                       dot(p, frame.rows[3]));
}
