//! photon (in progress)
