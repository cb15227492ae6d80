//! Broad phase. STUB: filled in by the broad-phase work.
