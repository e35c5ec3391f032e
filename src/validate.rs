//! Benchmark invariants (to be written).
