#version 460
// Value check of a buffer of photon records (src/passes/value_check.rs): every float of every
// record is checked for NaN and ±Inf; only the three power floats at `power_offset` for
// negative values (positions and packed directions may be negative).
#include "value_check.glsl"

layout(local_size_x = 256) in;

layout(set = 0, binding = 1) readonly buffer Records {
    float records[];
};

layout(push_constant) uniform Push {
    uint count;         // records
    uint stride;        // floats per record
    uint power_offset;  // float index of the power (RGB) within a record
    uint counter;
} push;

void main() {
    value_check_begin();
    uint non_finite = 0;
    uint negative = 0;
    uint values = 0;
    // Grid-stride: the dispatch is capped, so any number of records fits it.
    uint threads = gl_NumWorkGroups.x * gl_WorkGroupSize.x;
    for (uint r = gl_GlobalInvocationID.x; r < push.count; r += threads) {
        for (uint f = 0; f < push.stride; ++f) {
            float v = records[r * push.stride + f];
            non_finite += uint(value_non_finite(v));
            if (f - push.power_offset < 3u) {
                negative += uint(value_negative(v));
            }
        }
        values += push.stride;
    }
    value_check_end(push.counter, non_finite, negative, values);
}
