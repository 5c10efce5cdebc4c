//! Counter-based random numbers (placeholder module; the Monte Carlo issue fills it in).
