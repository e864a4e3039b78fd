"""Float64 numpy references for tests and benchmarks (independent of the native core)."""
