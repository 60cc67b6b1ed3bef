//! Scenes built in Rust: a hanging cloth and a tetrahedral jelly block.

pub mod cloth;
pub mod jelly;

/// Sorted, deduplicated undirected edges `(i, j)` with `i < j` — deterministic, no hash
/// maps.
pub(crate) fn unique_edges(mut e: Vec<(usize, usize)>) -> Vec<(usize, usize)> {
    for p in &mut e {
        if p.0 > p.1 {
            *p = (p.1, p.0);
        }
    }
    e.sort_unstable();
    e.dedup();
    e
}
