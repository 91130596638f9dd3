//! Cross-crate integration tests: the layers used together as a downstream user would.

mod pipeline;
