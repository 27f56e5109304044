//! (bsdf work in progress)
