// HLSL as engines write it: a row_major push-constant matrix, mul(matrix, vector).
struct PC { row_major float4x4 mvp; float4 color; };
[[vk::push_constant]] PC pc;
struct Out { float4 pos : SV_Position; float4 color : COLOR0; };
Out main(float3 position : POSITION) {
    Out o;
    o.pos = mul(pc.mvp, float4(position, 1.0));
    o.color = pc.color;
    return o;
}
