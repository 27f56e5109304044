// The value check's counting (src/passes/value_check.rs): what counts as a bad value, and the
// workgroup's sums, added to its counters once per workgroup.
#ifndef VALUE_CHECK_GLSL
#define VALUE_CHECK_GLSL

#include "shared.glsl"

layout(set = 0, binding = 0) buffer Counters {
    ValueCounters counters[];
};

shared uint group_non_finite;
shared uint group_negative;
shared uint group_values;

// Bit tests rather than isnan/isinf, which a compiler may fold away by assuming that floats
// are finite: all exponent bits set is NaN or ±Inf.
bool value_non_finite(float v) {
    return (floatBitsToUint(v) & 0x7f800000u) == 0x7f800000u;
}

// A finite value below zero: the sign bit and a non-zero magnitude (-0.0 is not negative).
bool value_negative(float v) {
    return floatBitsToUint(v) > 0x80000000u && !value_non_finite(v);
}

// Called first by every invocation of the workgroup (uniform control flow).
void value_check_begin() {
    if (gl_LocalInvocationIndex == 0) {
        group_non_finite = 0;
        group_negative = 0;
        group_values = 0;
    }
    memoryBarrierShared();
    barrier();
}

// Called last by every invocation of the workgroup (uniform control flow) with what it
// counted; one invocation adds the workgroup's sums to `counters[counter]`.
void value_check_end(uint counter, uint non_finite, uint negative, uint values) {
    if (non_finite > 0) {
        atomicAdd(group_non_finite, non_finite);
    }
    if (negative > 0) {
        atomicAdd(group_negative, negative);
    }
    atomicAdd(group_values, values);
    memoryBarrierShared();
    barrier();
    if (gl_LocalInvocationIndex == 0) {
        if (group_non_finite > 0) {
            atomicAdd(counters[counter].non_finite, group_non_finite);
        }
        if (group_negative > 0) {
            atomicAdd(counters[counter].negative, group_negative);
        }
        atomicAdd(counters[counter].values, group_values);
    }
}

#endif
