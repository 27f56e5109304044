// Deterministic random numbers: the twin of src/photon/rng.rs, bit for bit.
//
// pcg_hash: one LCG step + PCG's RXS-M-XS 32/32 permutation (Jarzynski & Olano, JCGT 2020).
// Rng: PCG RXS-M-XS 32/32 (period 2^32), one uint of state; floats are the top 24 bits * 2^-24.
// Seeds are frame-coherent (DESIGN.md §2.3): seed_bounce_map_texel hashes the light position
// bits and the texel index (the CPU references' twin); the bounce map seeds a texel from its
// view's light seed, a hash of the light's index (src/plan/bounce_plan.rs); -0.0 counts as +0.0.
//
// Test vectors (also `PCG_HASH_TEST_VECTORS` / `RNG_TEST_VECTORS` in rng.rs):
//   pcg_hash(0u) = 129708002u          pcg_hash(1u) = 2831084092u
//   pcg_hash(2u) = 2055130248u         pcg_hash(12345u) = 4099845390u
//   pcg_hash(0x80000000u) = 566699590u pcg_hash(0xffffffffu) = 3861530882u
//   rng_new(0u):  2354161293u, 817759070u, 3031337079u, 619535985u
//   rng_new(42u): 833113347u, 2785308739u, 391924586u, 3212367989u
#ifndef ISPM_RNG_GLSL
#define ISPM_RNG_GLSL

const uint RNG_LCG_MULTIPLIER = 747796405u;
const uint RNG_LCG_INCREMENT = 2891336453u;
const uint RNG_RXS_M_XS_MULTIPLIER = 277803737u;

uint rxs_m_xs(uint state) {
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * RNG_RXS_M_XS_MULTIPLIER;
    return (word >> 22u) ^ word;
}

uint pcg_hash(uint v) {
    return rxs_m_xs(v * RNG_LCG_MULTIPLIER + RNG_LCG_INCREMENT);
}

uint hash2(uint a, uint b) {
    return pcg_hash(pcg_hash(a) ^ b);
}

uint canonical_bits(float x) {
    return x == 0.0 ? 0u : floatBitsToUint(x);
}

uint hash_vec3(vec3 p) {
    return hash2(hash2(canonical_bits(p.x), canonical_bits(p.y)), canonical_bits(p.z));
}

uint seed_bounce_map_texel(vec3 light_position, uint texel, uint global_seed) {
    return hash2(hash2(hash_vec3(light_position), texel), global_seed);
}

uint seed_from_position(vec3 start, uint global_seed) {
    return hash2(hash_vec3(start), global_seed);
}

struct Rng {
    uint state;
};

Rng rng_new(uint seed) {
    return Rng(pcg_hash(seed));
}

uint rng_next_u32(inout Rng rng) {
    uint old = rng.state;
    rng.state = old * RNG_LCG_MULTIPLIER + RNG_LCG_INCREMENT;
    return rxs_m_xs(old);
}

float rng_next_f32(inout Rng rng) {
    return float(rng_next_u32(rng) >> 8u) * (1.0 / 16777216.0);
}

vec2 rng_next_2(inout Rng rng) {
    float a = rng_next_f32(rng);
    return vec2(a, rng_next_f32(rng));
}

vec3 rng_next_3(inout Rng rng) {
    float a = rng_next_f32(rng);
    float b = rng_next_f32(rng);
    return vec3(a, b, rng_next_f32(rng));
}

#endif
