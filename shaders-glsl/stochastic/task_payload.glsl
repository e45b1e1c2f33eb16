// What the task shader (stochastic.task) hands the mesh workgroups it launches: the triangles of its
// cluster that may cover a sample, in the draw's order. Included by both stages.
#ifndef SHUTTER_TASK_PAYLOAD_GLSL
#define SHUTTER_TASK_PAYLOAD_GLSL

// Triangles per task workgroup (one per invocation): TASK_CLUSTER in the Rust side's grid
// (techniques/stochastic/mod.rs).
#define TASK_CLUSTER 32

struct TaskPayload {
    uint triangle[TASK_CLUSTER];
};

#endif
