#version 460
// The graph probe's repeat test (tests/tests/graph.rs): one invocation per pass adds 1 to a counter
// and records the count it saw, so a repeat node of N passes leaves N and 0, 1, ..., N-1 in order —
// across submissions, with the graph's barriers between the passes.
layout(local_size_x = 1) in;
layout(set = 3, binding = 0, std430) buffer Counts { uint counts[]; };  // [0]: counter, [1 + k]: pass k
layout(push_constant) uniform Push { uint pass_index; } pc;
void main() {
    uint seen = counts[0];
    counts[1u + pc.pass_index] = seen;
    counts[0] = seen + 1u;
}
