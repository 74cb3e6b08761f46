//! The pod's configuration.
