//! Nori's XML dialect.
