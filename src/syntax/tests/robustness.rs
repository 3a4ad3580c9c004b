//! No input panics, hangs or overflows the stack.
