//! Light transport on the CPU: the über-BSDF, photon records, random numbers, ray tracing
//! against a BVH, and the photon tracer. Never touches Vulkan.

pub mod bsdf;
pub mod bvh;
pub mod density;
pub mod emit;
pub mod kernel;
pub mod progressive;
pub mod ray;
pub mod rng;
pub mod sampling;
pub mod shapes;
pub mod trace;
pub mod triangle;
pub mod types;

#[cfg(test)]
mod tracing_tests;
