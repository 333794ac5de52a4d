//! Rerun logging (placeholder until the rerun build is added).
