//! Format-neutral scene tree with file positions.
