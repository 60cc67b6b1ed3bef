//! Shapes and contact generation.
