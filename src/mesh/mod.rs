//! Welded topology (placeholder).
