//! The seed report's 15-axis separating-axis test (Eberly, Appendix A) and
//! the unique first-contact point (Appendix B). STUB: filled in by the collision work.
