// HLSL impostor: SV_Position in, SV_Depth out (glslang passes the position to a wrapped
// function through a pointer, the pattern the rewrite refuses or follows).
struct In { float4 pos : SV_Position; float2 uv : TEXCOORD0; };
struct Out { float4 color : SV_Target0; float depth : SV_Depth; };
Out main(In i) {
    Out o;
    float r = dot(i.uv, i.uv);
    o.color = float4(i.uv, r, 1.0);
    o.depth = i.pos.z + (1.0 - r) * 0.01;
    return o;
}
