//! (geometry work in progress)
