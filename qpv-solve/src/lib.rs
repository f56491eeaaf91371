//! qpv solver.
