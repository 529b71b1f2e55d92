//! Typed property lookup with defaults and positioned errors.
