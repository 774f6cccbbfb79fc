//! rapier
