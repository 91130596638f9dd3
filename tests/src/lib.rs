//! Cross-crate integration tests of dgsph live in `tests/tests/`; this library is empty.
