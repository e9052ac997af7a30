// mul(vector, matrix): the vector on the left, column_major storage.
struct PC { float4x4 view; float4x4 proj; };
[[vk::push_constant]] PC pc;
float4 main(float3 position : POSITION) : SV_Position {
    return mul(mul(float4(position, 1.0), pc.view), pc.proj);
}
